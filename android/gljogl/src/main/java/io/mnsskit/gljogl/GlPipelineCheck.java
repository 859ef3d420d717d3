package io.mnsskit.gljogl;

import com.jogamp.opengl.GL;
import io.mnsskit.core.GpuFramePipeline;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.Schedule;
import io.mnsskit.core.SelfTest;
import io.mnsskit.core.TensorComparator;
import java.io.File;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * Runs the app's frame pipeline ({@link GpuFramePipeline}, the classes the phone runs) on this
 * machine's OpenGL ES over a bundle's golden frames, the NPU step answered from the golden files,
 * and holds every tensor the GL side produced to the golden values: integer tensors bit-exact,
 * float tensors within {@link #FLOAT_TOLERANCE}.  Prints one line per tensor and frame, then
 * {@code compared T tensors V values, W wrong}; exits 1 unless W is 0.
 *
 * <pre>  java -Djogl.disable.opengldesktop io.mnsskit.gljogl.GlPipelineCheck BUNDLE   (EGL_PLATFORM=surfaceless)</pre>
 */
public final class GlPipelineCheck {
    static final double FLOAT_TOLERANCE = 1e-3;

    private GlPipelineCheck() {
    }

    public static void main(String[] args) {
        File bundle = new File(args[0]);
        Manifest manifest = Manifest.load(bundle);
        List<TensorComparator.Result> results;
        try (JoglContext context = new JoglContext()) {
            System.out.println("gl " + context.gl().glGetString(GL.GL_VERSION) + " | " + context.gl().glGetString(GL.GL_RENDERER));
            try (GpuFramePipeline pipeline = new GpuFramePipeline(new JoglGles31(context.gl()), manifest, bundle, goldenNpu(bundle, manifest))) {
                results = SelfTest.run(bundle, manifest, pipeline, null).results;
            }
        }
        // The NPU outputs are the golden files echoed back: comparing them would prove nothing.
        Schedule.Step npuStep = manifest.schedule.npuStep();
        // A bundle with a float path through the driver's pow() (demodulation) may move a code downstream of it.
        boolean floatPath = manifest.gpu.passes.values().stream().anyMatch(p -> !p.exact);
        int allowedLsb = floatPath ? 1 : 0;
        System.out.println("int8 and 8-bit tensors: " + (floatPath ? "within 1 LSB (a pass is a float path)" : "bit-exact"));
        long tensors = 0;
        long values = 0;
        int wrong = 0;
        for (TensorComparator.Result r : results) {
            if (npuStep.outputs.containsValue(r.name)) {
                continue;
            }
            boolean ok = r.inLsb ? r.maxDiff <= allowedLsb : r.maxDiff <= FLOAT_TOLERANCE;
            System.out.println((ok ? "ok    " : "WRONG ") + r.summary());
            tensors++;
            values += r.count;
            wrong += ok ? 0 : 1;
        }
        System.out.println("compared " + tensors + " tensors " + values + " values, " + wrong + " wrong");
        System.exit(wrong == 0 && tensors > 0 ? 0 : 1);
    }

    /** The NPU step of golden frame t (the t-th call) answered with frame t's golden output buffers. */
    private static GpuFramePipeline.Npu goldenNpu(File bundle, Manifest manifest) {
        int[] frame = {0};
        return inputs -> {
            Map<String, byte[]> out = new LinkedHashMap<>();
            manifest.schedule.npuStep().outputs.forEach(
                    (tensor, resource) -> out.put(tensor, manifest.golden.frames.get(frame[0]).read(bundle, resource).data));
            frame[0]++;
            return out;
        };
    }
}
