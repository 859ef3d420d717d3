package io.mnsskit.core;

import java.io.File;
import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * A frame's GPU side through {@link Gles31}: the bundle's resources allocated from the manifest,
 * its compute shaders compiled from its files, the plan's GPU steps before the NPU step, the int8
 * NPU buffers read back and written, the steps after it and the output read back.  The NPU call
 * is the caller's ({@link Npu}): LiteRT on the phone, the golden files in the desktop test, so the
 * phone and the desk run these same classes.
 *
 * <p>GPU -> NPU handoff here is a copy: the packed int8 SSBO is mapped and handed to the NPU, its
 * output written back with glBufferSubData (the bytes are the tensor, no repacking).
 */
public final class GpuFramePipeline implements SelfTest.Pipeline, AutoCloseable {
    /** The NPU step: int8 NHWC bytes by model tensor name in, the same out. */
    public interface Npu {
        Map<String, byte[]> run(Map<String, byte[]> inputs);
    }

    private final Manifest manifest;
    private final GlResources resources;
    private final ComputePasses passes;
    private final Npu npu;
    private FrameTimer timer;

    /** Allocates every resource and compiles every pass; needs a current GL ES 3.1 context. */
    public GpuFramePipeline(Gles31 gl, Manifest manifest, File bundle, Npu npu) {
        this.manifest = manifest;
        this.npu = npu;
        resources = new GlResources(gl, manifest, bundle);
        passes = new ComputePasses(gl, manifest, bundle);
    }

    /** Times every GPU step and the NPU call of the frames that follow with {@code timer} (null: untimed). */
    public void timeWith(FrameTimer timer) {
        this.timer = timer;
    }

    /**
     * One whole frame: {@code inputs} (input resource name to tensor) uploaded, the GPU steps, the
     * NPU (timed as {@link #npuStage}), the steps after it; returns the codes
     * of the output resource.
     */
    public byte[] frame(FrameScheduler.FramePlan plan, Map<String, Tensor> inputs) {
        Schedule.Step npuStep = manifest.schedule.npuStep();
        Map<String, byte[]> buffers = beforeNpu(plan, inputs, new ArrayList<>(npuStep.inputs.values()));
        Map<String, byte[]> byTensor = new LinkedHashMap<>();
        npuStep.inputs.forEach((tensor, resource) -> byTensor.put(tensor, buffers.get(resource)));
        Map<String, byte[]> result = timer == null ? npu(byTensor) : timer.cpu(npuStage(npuStep), () -> npu(byTensor));
        return afterNpu(plan, SelfTest.byResource(npuStep.outputs, result), manifest.golden.output);
    }

    /** The timing stage of the NPU step. */
    public static String npuStage(Schedule.Step npuStep) {
        return "NPU " + npuStep.label;
    }

    /** The current values of 2D float texture {@code name} (logical name, as the plan maps it). */
    public float[] readFloats(FrameScheduler.FramePlan plan, String name) {
        return resources.readFloats(plan.physical(name));
    }

    private void dispatch(FrameScheduler.PlannedStep step) {
        if (timer != null) {
            timer.gpuBegin(step.step.label);
        }
        passes.dispatch(step, resources);
        if (timer != null) {
            timer.gpuEnd();
        }
    }

    @Override
    public Map<String, byte[]> beforeNpu(FrameScheduler.FramePlan plan, Map<String, Tensor> inputs, List<String> npuInputs) {
        inputs.forEach((name, tensor) -> resources.uploadTexture(plan.physical(name), tensor));
        for (FrameScheduler.PlannedStep step : plan.steps) {
            if (step.step.kind == Schedule.Kind.NPU) {
                break;
            }
            dispatch(step);
        }
        Map<String, byte[]> out = new LinkedHashMap<>();
        for (String buffer : npuInputs) {
            out.put(buffer, resources.readBuffer(plan.physical(buffer), manifest.golden.boundaryOf(buffer).count()));
        }
        return out;
    }

    @Override
    public Map<String, byte[]> npu(Map<String, byte[]> inputs) {
        return npu.run(inputs);
    }

    @Override
    public byte[] afterNpu(FrameScheduler.FramePlan plan, Map<String, byte[]> npuOutputs, String output) {
        npuOutputs.forEach((buffer, bytes) -> resources.writeBuffer(plan.physical(buffer), bytes));
        boolean afterNpu = false;
        for (FrameScheduler.PlannedStep step : plan.steps) {
            if (afterNpu) {
                dispatch(step);
            }
            afterNpu |= step.step.kind == Schedule.Kind.NPU;
        }
        return resources.readRgb8(plan.physical(output));
    }

    @Override
    public void close() {
        passes.close();
        resources.close();
    }
}
