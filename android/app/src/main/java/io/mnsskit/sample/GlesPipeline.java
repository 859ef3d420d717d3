package io.mnsskit.sample;

import io.mnsskit.core.BundleException;
import io.mnsskit.core.FrameScheduler;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.Schedule;
import io.mnsskit.core.SelfTest;
import io.mnsskit.core.Tensor;
import java.io.File;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * A frame on the device: the plan's GPU steps up to the NPU step, the NPU, the GPU steps after
 * it.  Implements the self-test's {@link SelfTest.Pipeline}; an engine integration drives the
 * same objects with {@link FrameScheduler#next(boolean)} once per frame, its own textures in the
 * plan's input resources (whatever the manifest lists as {@code input}).
 *
 * <p>GPU -> NPU handoff here is a copy: the packed int8 SSBO is mapped and handed to LiteRT, the
 * output written back with glBufferSubData (the bytes are the tensor, no repacking).  A shipping
 * integration shares the memory instead: an AHardwareBuffer (BLOB format, usage
 * GPU_DATA_BUFFER | CPU_READ/WRITE as the driver needs) imported into GL with
 * eglGetNativeClientBufferANDROID + glBufferStorageExternalEXT (GL_EXT_external_buffer) as the
 * SSBO, and into the NPU as ANeuralNetworksMemory_createFromAHardwareBuffer (NNAPI) or a LiteRT
 * TensorBuffer created from the AHardwareBuffer; the GPU's writes are handed over with an EGL
 * native fence (EGL_ANDROID_native_fence_sync) instead of glFinish.  That path needs the NDK and
 * is described in android/README.md; the numerics do not change.
 */
final class GlesPipeline implements SelfTest.Pipeline, AutoCloseable {
    private final Manifest manifest;
    private final GlResources resources;
    private final ComputePasses passes;
    private final NpuRunner npu;

    GlesPipeline(Manifest manifest, File bundle, NpuRunner.Accelerator accelerator) {
        this.manifest = manifest;
        resources = new GlResources(manifest, bundle);
        passes = new ComputePasses(manifest, bundle);
        npu = new NpuRunner(manifest, bundle, accelerator);
    }

    @Override
    public Map<String, byte[]> beforeNpu(FrameScheduler.FramePlan plan, Map<String, Tensor> inputs, List<String> npuInputs) {
        inputs.forEach((name, tensor) -> resources.uploadTexture(plan.physical(name), tensor));
        for (FrameScheduler.PlannedStep step : plan.steps) {
            if (step.step.kind == Schedule.Kind.NPU) {
                break;
            }
            passes.dispatch(step, resources);
        }
        Map<String, byte[]> out = new LinkedHashMap<>();
        for (String buffer : npuInputs) {
            out.put(buffer, resources.readBuffer(plan.physical(buffer), manifest.golden.boundaryOf(buffer).count()));
        }
        return out;
    }

    /** NpuRunner runs a single-input, single-output model (ScheduleCheck and NpuRunner check the model). */
    @Override
    public Map<String, byte[]> npu(Map<String, byte[]> inputs) {
        if (inputs.size() != 1 || manifest.npu.outputs.size() != 1) {
            throw new BundleException("this app runs NPU models with one input and one output; the manifest lists "
                    + inputs.size() + " and " + manifest.npu.outputs.size());
        }
        return Collections.singletonMap(manifest.npu.outputs.get(0), npu.run(inputs.values().iterator().next()));
    }

    @Override
    public byte[] afterNpu(FrameScheduler.FramePlan plan, Map<String, byte[]> npuOutputs, String output) {
        npuOutputs.forEach((buffer, bytes) -> resources.writeBuffer(plan.physical(buffer), bytes));
        boolean afterNpu = false;
        for (FrameScheduler.PlannedStep step : plan.steps) {
            if (afterNpu) {
                passes.dispatch(step, resources);
            }
            afterNpu |= step.step.kind == Schedule.Kind.NPU;
        }
        return resources.readRgb8(plan.physical(output));
    }

    @Override
    public void close() {
        npu.close();
        passes.close();
        resources.close();
    }
}
