package io.mnsskit.gljogl;

import com.jogamp.opengl.GL;
import io.mnsskit.core.DebugView;
import io.mnsskit.core.Golden;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.Player;
import io.mnsskit.core.Schedule;
import io.mnsskit.core.Tensor;
import io.mnsskit.core.TimingStats;
import java.io.File;
import java.io.IOException;
import java.nio.file.Files;
import java.util.Arrays;
import java.util.HashMap;
import java.util.LinkedHashMap;
import java.util.Map;

/**
 * Plays a bundle's recorded sequence with the app's {@link Player} (the phone's classes) on this
 * machine's OpenGL ES, {@code LOOPS} times round, the NPU step answered from the golden files.
 * On every sequence frame that is also a golden frame (the golden frames are the first frames of
 * the same sequence) the NPU's input buffers and the output must equal the golden bytes: the
 * frames run as a chain here, history and ping-pong state carried from frame to frame, and frame
 * 0 after the last is a reset.  Frames without golden values get golden frame
 * {@code t mod golden frames}'s NPU output (any valid int8 tensor keeps the loop going).  Every
 * frame also renders the bilinear upscale and every debug view.  Prints the timing table, then
 * {@code player: F frames, T tensors V values compared, W wrong}; exits 1 unless W is 0.  With
 * OUT, writes the first frame's bilinear codes ({@code bilinear.bin}) and debug view V of played
 * frame T ({@code view_T_V.bin}) there.
 *
 * <pre>  java -Djogl.disable.opengldesktop io.mnsskit.gljogl.PlayerCheck BUNDLE LOOPS [OUT [finish]]   (EGL_PLATFORM=surfaceless)</pre>
 * {@code finish}: time the GPU steps with glFinish and the system clock even where timer queries exist.
 */
public final class PlayerCheck {
    private PlayerCheck() {
    }

    public static void main(String[] args) throws IOException {
        File bundle = new File(args[0]);
        int loops = Integer.parseInt(args[1]);
        File out = args.length > 2 && !args[2].isEmpty() ? new File(args[2]) : null;
        boolean timerQueries = args.length <= 3 || !args[3].equals("finish");
        Manifest manifest = Manifest.load(bundle);
        Map<Integer, Golden.Frame> golden = new HashMap<>();
        for (Golden.Frame f : manifest.golden.frames) {
            golden.put(f.index, f);
        }
        Schedule.Step npuStep = manifest.schedule.npuStep();
        int[] current = {0};
        long[] counts = new long[3]; // tensors, values, wrong
        GoldenNpu npu = new GoldenNpu(bundle, manifest, golden, npuStep, current, counts);
        try (JoglContext context = new JoglContext();
             Player player = new Player(new JoglGles31(context.gl()), manifest, bundle, npu, timerQueries)) {
            System.out.println("gl " + context.gl().glGetString(GL.GL_VERSION) + " | " + context.gl().glGetString(GL.GL_RENDERER));
            System.out.println("timing: " + player.timing().label);
            int frames = loops * manifest.sequence.frames.size();
            for (int t = 0; t < frames; t++) {
                current[0] = t % manifest.sequence.frames.size();
                Player.Frame frame = player.next();
                byte[] bilinear = player.bilinear();
                Golden.Frame g = golden.get(frame.index);
                if (g != null) {
                    compare("frame " + frame.index + " " + manifest.golden.output, g.read(bundle, manifest.golden.output).data, frame.output, counts);
                }
                for (int v = 0; v < manifest.debugViews.size(); v++) {
                    byte[] view = player.debugView(manifest.debugViews.get(v));
                    if (out != null) {
                        Files.write(new File(out, "view_" + t + "_" + v + ".bin").toPath(), view);
                    }
                }
                if (out != null && t == 0) {
                    Files.write(new File(out, "bilinear.bin").toPath(), bilinear);
                }
            }
            TimingStats stats = player.stats();
            System.out.println(stats.describe(player.timing()));
            System.out.println("debug views: " + manifest.debugViews.stream().map(v -> v.name).reduce((a, b) -> a + ", " + b).orElse("none"));
            System.out.println("player: " + frames + " frames, " + counts[0] + " tensors " + counts[1] + " values compared, " + counts[2] + " wrong");
        }
        System.exit(counts[2] == 0 && counts[0] > 0 ? 0 : 1);
    }

    private static void compare(String what, byte[] expected, byte[] actual, long[] counts) {
        boolean same = Arrays.equals(expected, actual);
        int differing = 0;
        for (int i = 0; i < Math.min(expected.length, actual.length); i++) {
            differing += expected[i] != actual[i] ? 1 : 0;
        }
        System.out.println((same ? "ok    " : "WRONG ") + what + ": " + expected.length + " bytes, " + differing + " differ");
        counts[0]++;
        counts[1] += expected.length;
        counts[2] += same ? 0 : 1;
    }

    /** The NPU step answered from the golden files; its inputs held to the golden ones where there are any. */
    private static final class GoldenNpu implements io.mnsskit.core.GpuFramePipeline.Npu {
        private final File bundle;
        private final Map<Integer, Golden.Frame> golden;
        private final Schedule.Step npuStep;
        private final int[] current;
        private final long[] counts;
        private final java.util.List<Golden.Frame> frames;

        GoldenNpu(File bundle, Manifest manifest, Map<Integer, Golden.Frame> golden, Schedule.Step npuStep, int[] current, long[] counts) {
            this.bundle = bundle;
            this.golden = golden;
            this.npuStep = npuStep;
            this.current = current;
            this.counts = counts;
            frames = manifest.golden.frames;
        }

        @Override
        public Map<String, byte[]> run(Map<String, byte[]> inputs) {
            Golden.Frame exact = golden.get(current[0]);
            if (exact != null) {
                npuStep.inputs.forEach((tensor, resource) -> compare("frame " + current[0] + " " + resource,
                        exact.read(bundle, resource).data, inputs.get(tensor), counts));
            }
            Golden.Frame answer = exact != null ? exact : frames.get(current[0] % frames.size());
            Map<String, byte[]> out = new LinkedHashMap<>();
            npuStep.outputs.forEach((tensor, resource) -> {
                Tensor t = answer.read(bundle, resource);
                out.put(tensor, t.data);
            });
            return out;
        }
    }
}
