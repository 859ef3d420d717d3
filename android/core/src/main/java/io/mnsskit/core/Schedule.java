package io.mnsskit.core;

import java.util.ArrayList;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * The per-frame steps of a manifest, as written: GPU dispatches (pass, bindings to resources or
 * weight blocks, uniforms, workgroup counts) and the NPU invocation, in order; the resource
 * swaps at the end of a frame; the rules for reset frames and barriers as text.
 * {@link FrameScheduler} turns it into what runs in one given frame.
 */
public final class Schedule {
    /** A step binds {@code weights:NAME} to bind block NAME of the weight file. */
    public static final String WEIGHTS_PREFIX = "weights:";

    public final List<Step> steps;
    /** Pairs of resource names whose contents trade places at the end of each frame. */
    public final List<String[]> endOfFrameSwaps;
    public final String resetRule;
    public final String barriers;

    /** Per-frame uniform sources ({@code {"frame": KEY}} in the manifest). */
    public enum FrameValue {
        OFFSET("offset"), SUBPIXEL("subpixel"), PREVIOUS_OFFSET("previous_offset"),
        PREVIOUS_SUBPIXEL("previous_subpixel"), RESET("reset");

        public final String key;

        FrameValue(String key) {
            this.key = key;
        }

        static FrameValue read(Json j) {
            for (FrameValue v : values()) {
                if (v.key.equals(j.asString())) {
                    return v;
                }
            }
            throw new BundleException(j.path() + " unknown per-frame value '" + j.asString() + "'");
        }
    }

    /** A uniform's value: a constant (numbers, integral or not) or a per-frame value. */
    public static final class UniformSource {
        /** Null for a per-frame value. */
        public final double[] constant;
        public final boolean integral;
        /** Null for a constant. */
        public final FrameValue frame;

        private UniformSource(double[] constant, boolean integral, FrameValue frame) {
            this.constant = constant;
            this.integral = integral;
            this.frame = frame;
        }

        static UniformSource read(Json j) {
            if (j.has("frame")) {
                return new UniformSource(null, false, FrameValue.read(j.get("frame")));
            }
            Json v = j.get("value");
            List<Json> items = v.isArray() ? v.items() : Collections.singletonList(v);
            double[] values = new double[items.size()];
            boolean integral = true;
            for (int i = 0; i < values.length; i++) {
                values[i] = items.get(i).asDouble();
                integral &= items.get(i).isIntegral();
            }
            return new UniformSource(values, integral, null);
        }
    }

    public enum Kind { GPU, NPU }

    /** One step; GPU fields are null/empty for the NPU step and the other way round. */
    public static final class Step {
        public final Kind kind;
        public final String label;
        public final String stage;
        // GPU
        public final String pass;
        /** Shader binding name to resource name or {@code weights:BLOCK}. */
        public final Map<String, String> bind;
        public final Map<String, UniformSource> uniforms;
        public final int[] groups;
        public final boolean skipOnReset;
        // NPU
        public final String model;
        /** NPU tensor name to the resource holding it. */
        public final Map<String, String> inputs;
        public final Map<String, String> outputs;

        Step(Json j) {
            String kindName = j.get("kind").asString();
            label = j.get("label").asString();
            stage = j.get("stage").asString();
            if ("gpu".equals(kindName)) {
                kind = Kind.GPU;
                pass = j.get("pass").asString();
                bind = strings(j.get("bind"));
                Map<String, UniformSource> u = new LinkedHashMap<>();
                Json uj = j.get("uniforms");
                for (String name : uj.keys()) {
                    u.put(name, UniformSource.read(uj.get(name)));
                }
                uniforms = Collections.unmodifiableMap(u);
                groups = j.get("groups").asIntArray();
                if (groups.length != 3) {
                    throw new BundleException(j.path() + " groups needs 3 values");
                }
                skipOnReset = j.get("skip_on_reset").asBool();
                model = null;
                inputs = Collections.emptyMap();
                outputs = Collections.emptyMap();
            } else if ("npu".equals(kindName)) {
                kind = Kind.NPU;
                pass = null;
                bind = Collections.emptyMap();
                uniforms = Collections.emptyMap();
                groups = null;
                skipOnReset = false;
                model = j.get("model").asString();
                inputs = strings(j.get("inputs"));
                outputs = strings(j.get("outputs"));
            } else {
                throw new BundleException(j.get("kind").path() + " step kind must be 'gpu' or 'npu', not '" + kindName + "'");
            }
        }
    }

    Schedule(Json j) {
        List<Step> list = new ArrayList<>();
        for (Json s : j.get("steps").items()) {
            list.add(new Step(s));
        }
        steps = Collections.unmodifiableList(list);
        List<String[]> swaps = new ArrayList<>();
        for (Json e : j.get("end_of_frame").items()) {
            Json pair = Manifest.pair(e.get("swap"));
            swaps.add(new String[] {pair.at(0).asString(), pair.at(1).asString()});
        }
        endOfFrameSwaps = Collections.unmodifiableList(swaps);
        resetRule = j.get("reset").asString();
        Json b = j.opt("barriers");
        barriers = b == null ? "" : b.asString();
    }

    /** The one NPU step ({@link ScheduleCheck} holds that there is exactly one). */
    public Step npuStep() {
        for (Step s : steps) {
            if (s.kind == Kind.NPU) {
                return s;
            }
        }
        throw new BundleException("manifest.json: schedule has no NPU step");
    }

    private static Map<String, String> strings(Json j) {
        Map<String, String> out = new LinkedHashMap<>();
        for (String key : j.keys()) {
            out.put(key, j.get(key).asString());
        }
        return Collections.unmodifiableMap(out);
    }
}
