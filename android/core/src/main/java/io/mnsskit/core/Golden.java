package io.mnsskit.core;

import java.io.File;
import java.util.ArrayList;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * The golden frames of a bundle: a few consecutive frames' inputs (as the input textures hold
 * them) and the tensors a phone reads back, computed on a desk by the reference GPU passes and
 * the NPU model under {@link #profile}'s kernels.  Arrays are raw little-endian files:
 *
 * <pre>
 *   color       (h, w, 3) float16     depth   (h, w, 1) float32     motion (h, w, 2) float32
 *   npu_input   (1, H, W, 3) int8     npu_output (1, H, W, 3) int8  display (H, W, 3) uint8
 * </pre>
 */
public final class Golden {
    public static final String[] INPUTS = {"color", "depth", "motion"};
    public static final String[] OUTPUTS = {"npu_input", "npu_output", "display"};

    public final String profile;
    public final String source;
    /** {@code npu_input_lsb}, {@code npu_output_lsb}, {@code display_codes}, {@code note}. */
    public final Json tolerances;
    public final List<Frame> frames;

    public static final class Array {
        public final String file;
        public final Tensor.DType dtype;
        public final int[] shape;

        Array(Json j) {
            file = j.get("file").asString();
            dtype = Tensor.DType.of(j.get("dtype").asString());
            shape = Manifest.shape(j.get("shape"));
        }
    }

    public static final class Frame {
        public final int index;
        public final boolean reset;
        public final float[] jitter;
        public final int[] subpixel;
        /** Index of the matching jitter table entry, or null if the frame's jitter is not in the table. */
        public final Integer jitterIndex;
        public final Map<String, Array> arrays;

        Frame(Json j) {
            index = j.get("index").asInt();
            reset = j.get("reset").asBool();
            jitter = Manifest.pair(j.get("jitter")).asFloatArray();
            subpixel = Manifest.pair(j.get("subpixel")).asIntArray();
            Json ji = j.get("jitter_index");
            jitterIndex = ji.isNull() ? null : ji.asInt();
            Map<String, Array> map = new LinkedHashMap<>();
            Json aj = j.get("arrays");
            for (String key : aj.keys()) {
                map.put(key, new Array(aj.get(key)));
            }
            for (String required : concat(INPUTS, OUTPUTS)) {
                if (!map.containsKey(required)) {
                    throw new BundleException(aj.path() + " missing golden array '" + required + "'");
                }
            }
            arrays = Collections.unmodifiableMap(map);
        }

        /** The frame's jitter as a table entry (sub-pixel as stored with the frame). */
        public Manifest.JitterEntry jitterEntry() {
            return new Manifest.JitterEntry(jitterIndex == null ? -1 : jitterIndex, jitter[0], jitter[1], subpixel[0], subpixel[1]);
        }

        /**
         * Reads array {@code key} from {@code bundle}; the boundary tensors get the scale and
         * zero point of the manifest's boundary entry of the same role.
         */
        public Tensor read(File bundle, String key, Manifest manifest) {
            Array a = arrays.get(key);
            if (a == null) {
                throw new BundleException("golden frame " + index + " has no array '" + key + "'");
            }
            Float scale = null;
            int zeroPoint = 0;
            if (key.equals("npu_input") || key.equals("npu_output")) {
                NpuSection.Boundary b = manifest.boundary(key);
                scale = b.scale;
                zeroPoint = b.zeroPoint;
            }
            return Tensor.read(new File(bundle, a.file), key, a.dtype, a.shape, scale, zeroPoint);
        }
    }

    Golden(Json j) {
        profile = j.get("profile").asString();
        source = j.get("source").asString();
        tolerances = j.get("tolerances");
        List<Frame> list = new ArrayList<>();
        for (Json f : j.get("frames").items()) {
            list.add(new Frame(f));
        }
        frames = Collections.unmodifiableList(list);
    }

    /** Allowed difference for a golden output: LSBs for the NPU tensors, codes for the display. */
    public int toleranceFor(String key) {
        String name = key.equals("display") ? "display_codes" : key + "_lsb";
        Json t = tolerances.opt(name);
        return t == null ? 0 : t.asInt();
    }

    private static String[] concat(String[] a, String[] b) {
        String[] out = new String[a.length + b.length];
        System.arraycopy(a, 0, out, 0, a.length);
        System.arraycopy(b, 0, out, a.length, b.length);
        return out;
    }
}
