package io.mnsskit.core;

import java.util.ArrayList;
import java.util.Collections;
import java.util.HashMap;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * Which steps run in a frame, with what bound and which uniform values.
 *
 * <ul>
 *   <li>Jitter: frame {@code t} of the sequence uses table entry {@code t mod period}; the
 *       engine must render frame {@code t} with that projection offset ({@link FramePlan#jitter}).
 *   <li>Reset: the first frame and a camera cut skip the steps marked {@code skip_on_reset}
 *       (warp, inpainting weights) and get {@code reset = 1}: history is ignored.
 *   <li>Ping-pong: resources named in an end-of-frame swap (this frame's depth becomes the next
 *       frame's {@code prev_depth}) trade their physical allocations instead of being copied.
 *       A plan's bindings name physical resources; {@link FramePlan#physical} maps a logical
 *       name (where the engine writes this frame's depth) to its allocation.
 * </ul>
 *
 * The constructor checks the schedule against the passes, resources and weight blocks it names,
 * so a bad bundle fails before any GL object exists.
 */
public final class FrameScheduler {
    private final Manifest manifest;
    private final Map<String, String> physical = new HashMap<>();
    private long frameCount;
    private Manifest.JitterEntry previousJitter;

    /** A uniform's value for one frame; the app converts it to the GL type the shader declares. */
    public static final class Uniform {
        public final double[] values;
        public final boolean integral;

        Uniform(double[] values, boolean integral) {
            this.values = values;
            this.integral = integral;
        }

        public int[] ints() {
            int[] out = new int[values.length];
            for (int i = 0; i < out.length; i++) {
                out[i] = (int) values[i];
            }
            return out;
        }

        /** The values as float32 (the toolkit wrote float32 numbers, so exact). */
        public float[] floats() {
            float[] out = new float[values.length];
            for (int i = 0; i < out.length; i++) {
                out[i] = (float) values[i];
            }
            return out;
        }
    }

    /** One step of one frame: resolved bindings (physical resources or {@code weights:NAME}) and uniforms. */
    public static final class PlannedStep {
        public final Schedule.Step step;
        /** The shader of a GPU step; null for the NPU step. */
        public final GpuSection.Pass pass;
        public final Map<String, String> bind;
        public final Map<String, Uniform> uniforms;

        PlannedStep(Schedule.Step step, GpuSection.Pass pass, Map<String, String> bind, Map<String, Uniform> uniforms) {
            this.step = step;
            this.pass = pass;
            this.bind = bind;
            this.uniforms = uniforms;
        }
    }

    public static final class FramePlan {
        public final long frame;
        public final boolean reset;
        public final Manifest.JitterEntry jitter;
        public final Manifest.JitterEntry previousJitter;
        public final List<PlannedStep> steps;
        private final Map<String, String> physical;

        FramePlan(long frame, boolean reset, Manifest.JitterEntry jitter, Manifest.JitterEntry previousJitter,
                  List<PlannedStep> steps, Map<String, String> physical) {
            this.frame = frame;
            this.reset = reset;
            this.jitter = jitter;
            this.previousJitter = previousJitter;
            this.steps = steps;
            this.physical = physical;
        }

        /** The allocation that holds logical resource {@code name} in this frame. */
        public String physical(String name) {
            String p = physical.get(name);
            if (p == null) {
                throw new BundleException("no resource named '" + name + "'");
            }
            return p;
        }

        /** Labels of the steps that run, in order (for logs and tests). */
        public List<String> labels() {
            List<String> out = new ArrayList<>();
            for (PlannedStep s : steps) {
                out.add(s.step.label);
            }
            return out;
        }
    }

    public FrameScheduler(Manifest manifest) {
        List<String> problems = ScheduleCheck.problems(manifest);
        if (!problems.isEmpty()) {
            throw new BundleException(problems.get(0) + (problems.size() > 1 ? " (and " + (problems.size() - 1) + " more)" : ""));
        }
        this.manifest = manifest;
        for (GpuSection.Resource r : manifest.resources) {
            physical.put(r.name, r.name);
        }
    }

    /** The next frame of a sequence, jitter from the table; the first frame is always a reset. */
    public FramePlan next(boolean cameraCut) {
        return plan(manifest.jitter.forFrame(frameCount), cameraCut);
    }

    /**
     * The next frame with an explicit jitter entry (a golden frame's).  Swaps the end-of-frame
     * pairs of the previous frame first, so call once per frame, in order.
     */
    public FramePlan plan(Manifest.JitterEntry jitter, boolean cameraCut) {
        if (frameCount > 0) {
            for (String[] swap : manifest.schedule.endOfFrameSwaps) {
                String a = physical.get(swap[0]);
                physical.put(swap[0], physical.get(swap[1]));
                physical.put(swap[1], a);
            }
        }
        boolean reset = cameraCut || frameCount == 0;
        // The previous frame's entry, also on a cut (as mnss_kit/gpu/interpret.py): only the first frame has none.
        Manifest.JitterEntry previous = previousJitter == null ? jitter : previousJitter;
        List<PlannedStep> steps = new ArrayList<>();
        for (Schedule.Step step : manifest.schedule.steps) {
            if (reset && step.skipOnReset) {
                continue;
            }
            steps.add(resolve(step, jitter, previous, reset));
        }
        FramePlan plan = new FramePlan(frameCount, reset, jitter, previous, Collections.unmodifiableList(steps),
                Collections.unmodifiableMap(new HashMap<>(physical)));
        frameCount++;
        previousJitter = jitter;
        return plan;
    }

    private PlannedStep resolve(Schedule.Step step, Manifest.JitterEntry jitter, Manifest.JitterEntry previous, boolean reset) {
        if (step.kind == Schedule.Kind.NPU) {
            Map<String, String> bind = new LinkedHashMap<>();
            step.inputs.forEach((tensor, resource) -> bind.put(tensor, physical.get(resource)));
            step.outputs.forEach((tensor, resource) -> bind.put(tensor, physical.get(resource)));
            return new PlannedStep(step, null, Collections.unmodifiableMap(bind), Collections.emptyMap());
        }
        Map<String, String> bind = new LinkedHashMap<>();
        for (Map.Entry<String, String> e : step.bind.entrySet()) {
            String target = e.getValue();
            bind.put(e.getKey(), target.startsWith(Schedule.WEIGHTS_PREFIX) ? target : physical.get(target));
        }
        Map<String, Uniform> uniforms = new LinkedHashMap<>();
        for (Map.Entry<String, Schedule.UniformSource> e : step.uniforms.entrySet()) {
            uniforms.put(e.getKey(), value(e.getValue(), jitter, previous, reset));
        }
        return new PlannedStep(step, manifest.gpu.passes.get(step.pass), Collections.unmodifiableMap(bind),
                Collections.unmodifiableMap(uniforms));
    }

    static Uniform value(Schedule.UniformSource source, Manifest.JitterEntry jitter, Manifest.JitterEntry previous, boolean reset) {
        if (source.frame == null) {
            return new Uniform(source.constant.clone(), source.integral);
        }
        switch (source.frame) {
            case OFFSET: return new Uniform(new double[] {jitter.offsetX, jitter.offsetY}, false);
            case SUBPIXEL: return new Uniform(new double[] {jitter.subpixelX, jitter.subpixelY}, true);
            case PREVIOUS_OFFSET: return new Uniform(new double[] {previous.offsetX, previous.offsetY}, false);
            case PREVIOUS_SUBPIXEL: return new Uniform(new double[] {previous.subpixelX, previous.subpixelY}, true);
            case RESET:
            default: return new Uniform(new double[] {reset ? 1 : 0}, true);
        }
    }
}
