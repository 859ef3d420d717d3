package io.mnsskit.core;

import java.io.File;
import java.util.ArrayList;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * The on-device self-test over a bundle's golden frames, independent of GL and LiteRT: a
 * {@link Pipeline} runs the three parts of a frame (the GPU steps before the schedule's NPU
 * step, the NPU step, the GPU steps after it) and this class feeds it, compares and dumps.
 * Nothing here names a resource: the inputs, the NPU step's buffers and the output come from
 * the manifest's resources and schedule ({@link Golden}).
 *
 * <p>Each part is fed the golden values, so a difference is charged to the part that made it
 * and does not travel through the recurrence: the GPU steps get the golden frame inputs (state
 * from the previous frame's golden NPU output); the NPU gets the golden NPU input buffers; the
 * steps after the NPU get the golden NPU output buffers.  Results pass within the bundle's
 * tolerances (1 LSB by default: phone GPUs may contract products into FMAs, NPU drivers may
 * round differently from the CPU kernels).
 *
 * <p>The device's tensors are written as a dump under the names the desktop emulator's dump
 * uses ({@code mnss-kit emulate --dump}): the NPU model's input and output tensor names and the
 * output resource's name, so {@code mnss-kit emulate --compare EMULATOR_DUMP DEVICE_DUMP}
 * matches them.
 */
public final class SelfTest {
    private SelfTest() {
    }

    /** The device side: the app implements it with GLES 3.1 compute and LiteRT. */
    public interface Pipeline {
        /**
         * Uploads {@code inputs} (input resource name to golden tensor) to {@code plan.physical(name)}
         * and runs the plan's GPU steps before the NPU step; returns the int8 NHWC bytes of each of
         * {@code npuInputs} (the NPU step's input buffers), by resource name.
         */
        Map<String, byte[]> beforeNpu(FrameScheduler.FramePlan plan, Map<String, Tensor> inputs, List<String> npuInputs);

        /** Runs the NPU model: int8 NHWC bytes by model tensor name in, the same out. */
        Map<String, byte[]> npu(Map<String, byte[]> inputs);

        /**
         * Writes {@code npuOutputs} (NPU output buffer name to int8 bytes) and runs the GPU steps
         * after the NPU step; returns the codes of resource {@code output} (H, W, channels).
         */
        byte[] afterNpu(FrameScheduler.FramePlan plan, Map<String, byte[]> npuOutputs, String output);
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
        Schedule.Step npuStep = manifest.schedule.npuStep();
        List<String> npuIn = new ArrayList<>(npuStep.inputs.values());
        List<String> npuOut = new ArrayList<>(npuStep.outputs.values());
        DumpWriter dump = dumpDir == null ? null : new DumpWriter(dumpDir, dumpInfo(manifest));
        Map<String, String> dumpNames = new LinkedHashMap<>(); // resource -> name in the dump
        Map<String, String> stages = new LinkedHashMap<>(); // name in the dump -> stage
        for (String r : concat(npuIn, npuOut)) {
            dumpNames.put(r, golden.boundaryOf(r).tensor);
            stages.put(golden.boundaryOf(r).tensor, "npu");
        }
        dumpNames.put(golden.output, golden.output);
        stages.put(golden.output, "gpu");
        List<TensorComparator.Result> results = new ArrayList<>();
        for (Golden.Frame frame : golden.frames) {
            FrameScheduler.FramePlan plan = scheduler.plan(frame.jitterEntry(), frame.reset);
            Map<String, Tensor> g = frame.read(bundle, concat(npuIn, npuOut, Collections.singletonList(golden.output)));
            Map<String, byte[]> gpuOut = pipeline.beforeNpu(plan, frame.read(bundle, golden.inputs), npuIn);
            Map<String, byte[]> npuResult = byResource(npuStep.outputs, pipeline.npu(byTensor(npuStep.inputs, g)));
            byte[] output = pipeline.afterNpu(plan, copies(g, npuOut), golden.output);
            List<Tensor> device = new ArrayList<>();
            for (String r : npuIn) {
                device.add(like(g.get(r), answer(gpuOut, r, "the GPU steps before the NPU")));
            }
            for (String r : npuOut) {
                device.add(like(g.get(r), answer(npuResult, r, "the NPU")));
            }
            device.add(like(g.get(golden.output), output));
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

    /** The golden bytes of the NPU step's buffers, keyed by model tensor name (fresh copies). */
    private static Map<String, byte[]> byTensor(Map<String, String> tensorToResource, Map<String, Tensor> golden) {
        Map<String, byte[]> out = new LinkedHashMap<>();
        tensorToResource.forEach((tensor, resource) -> out.put(tensor, golden.get(resource).data.clone()));
        return out;
    }

    /** The NPU's results, keyed by the buffer each output tensor goes to. */
    static Map<String, byte[]> byResource(Map<String, String> tensorToResource, Map<String, byte[]> byTensor) {
        Map<String, byte[]> out = new LinkedHashMap<>();
        tensorToResource.forEach((tensor, resource) -> {
            if (byTensor.containsKey(tensor)) {
                out.put(resource, byTensor.get(tensor));
            }
        });
        return out;
    }

    private static Map<String, byte[]> copies(Map<String, Tensor> golden, List<String> names) {
        Map<String, byte[]> out = new LinkedHashMap<>();
        for (String n : names) {
            out.put(n, golden.get(n).data.clone());
        }
        return out;
    }

    private static byte[] answer(Map<String, byte[]> answers, String resource, String who) {
        byte[] data = answers.get(resource);
        if (data == null) {
            throw new IllegalStateException(who + " returned nothing for '" + resource + "'");
        }
        return data;
    }

    @SafeVarargs
    private static List<String> concat(List<String>... lists) {
        List<String> out = new ArrayList<>();
        for (List<String> l : lists) {
            out.addAll(l);
        }
        return out;
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
