package io.mnsskit.core;

import java.io.File;
import java.util.ArrayList;
import java.util.Arrays;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * The on-device self-test over a bundle's golden frames, independent of GL and LiteRT: a
 * {@link Pipeline} runs the three parts of a frame and this class feeds it, compares and dumps.
 *
 * <p>Each part is fed the golden values, so a difference is charged to the part that made it
 * and does not travel through the recurrence: the GPU passes get the golden frame inputs
 * (history from the previous frame's golden NPU output); the NPU gets the golden
 * {@code npu_input}; the passes after the NPU get the golden {@code npu_output}.  Results pass
 * within the bundle's tolerances (1 LSB by default: phone GPUs may contract products into FMAs,
 * NPU drivers may round differently from the CPU kernels).
 *
 * <p>The device's tensors are written as a dump under the names the desktop emulator's dump
 * uses ({@code mnss-kit emulate --dump}): the NPU model's input and output tensor names and
 * {@code display}, so {@code mnss-kit emulate --compare EMULATOR_DUMP DEVICE_DUMP} matches them.
 */
public final class SelfTest {
    private SelfTest() {
    }

    /** The device side: the app implements it with GLES 3.1 compute and LiteRT. */
    public interface Pipeline {
        /** Uploads the frame inputs to the plan's input resources and runs the GPU steps before the NPU step; returns the int8 NHWC NPU input. */
        byte[] beforeNpu(FrameScheduler.FramePlan plan, Tensor color, Tensor depth, Tensor motion);

        /** Runs the NPU model on an int8 NHWC input; returns its int8 NHWC output. */
        byte[] npu(byte[] input);

        /** Writes {@code npuOutput} to the NPU output resource and runs the GPU steps after the NPU step; returns the display's RGB codes (H, W, 3). */
        byte[] afterNpu(FrameScheduler.FramePlan plan, byte[] npuOutput);
    }

    public static final class Report {
        public final List<TensorComparator.Result> results;

        Report(List<TensorComparator.Result> results) {
            this.results = results;
        }

        public boolean passed() {
            for (TensorComparator.Result r : results) {
                if (!r.passed()) {
                    return false;
                }
            }
            return !results.isEmpty();
        }

        public String summary() {
            StringBuilder out = new StringBuilder();
            for (TensorComparator.Result r : results) {
                out.append(r.summary()).append('\n');
            }
            return out.append(passed() ? "self-test PASSED" : "self-test FAILED").toString();
        }
    }

    /** Runs every golden frame through {@code pipeline}; writes the dump to {@code dumpDir} if not null. */
    public static Report run(File bundle, Manifest manifest, Pipeline pipeline, File dumpDir) {
        FrameScheduler scheduler = new FrameScheduler(manifest);
        Golden golden = manifest.golden;
        DumpWriter dump = dumpDir == null ? null : new DumpWriter(dumpDir, dumpInfo(manifest));
        Map<String, String> dumpNames = new LinkedHashMap<>();
        dumpNames.put("npu_input", manifest.boundary("npu_input").tensor);
        dumpNames.put("npu_output", manifest.boundary("npu_output").tensor);
        dumpNames.put("display", "display");
        Map<String, String> stages = new LinkedHashMap<>();
        stages.put(dumpNames.get("npu_input"), "npu");
        stages.put(dumpNames.get("npu_output"), "npu");
        stages.put("display", "gpu");
        List<TensorComparator.Result> results = new ArrayList<>();
        for (Golden.Frame frame : golden.frames) {
            Map<String, Tensor> g = new LinkedHashMap<>();
            for (String key : frame.arrays.keySet()) {
                g.put(key, frame.read(bundle, key, manifest));
            }
            FrameScheduler.FramePlan plan = scheduler.plan(frame.jitterEntry(), frame.reset);
            Tensor npuIn = like(g.get("npu_input"), pipeline.beforeNpu(plan, g.get("color"), g.get("depth"), g.get("motion")));
            Tensor npuOut = like(g.get("npu_output"), pipeline.npu(g.get("npu_input").data.clone()));
            Tensor display = like(g.get("display"), pipeline.afterNpu(plan, g.get("npu_output").data.clone()));
            List<Tensor> device = Arrays.asList(npuIn, npuOut, display);
            for (Tensor t : device) {
                results.add(TensorComparator.compare(t, g.get(t.name), frame.index, golden.toleranceFor(t.name)));
            }
            if (dump != null) {
                List<Tensor> named = new ArrayList<>();
                for (Tensor t : device) {
                    named.add(new Tensor(dumpNames.get(t.name), t.dtype, t.shape, t.scale, t.zeroPoint, t.data));
                }
                dump.writeFrame(frame.index, named, stages);
            }
        }
        return new Report(results);
    }

    /** A device result shaped and typed as the golden tensor it is compared with. */
    private static Tensor like(Tensor golden, byte[] data) {
        return new Tensor(golden.name, golden.dtype, golden.shape, golden.scale, golden.zeroPoint, data);
    }

    private static Map<String, Object> dumpInfo(Manifest m) {
        Map<String, Object> info = new LinkedHashMap<>();
        info.put("source", "mnss-kit Android self-test");
        info.put("model", m.model.id);
        info.put("golden_profile", m.golden.profile);
        info.put("mode", "isolated: each part fed the golden values");
        return info;
    }
}
