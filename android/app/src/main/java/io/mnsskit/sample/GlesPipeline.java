package io.mnsskit.sample;

import io.mnsskit.core.BundleException;
import io.mnsskit.core.FrameScheduler;
import io.mnsskit.core.GpuSection;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.NpuSection;
import io.mnsskit.core.Schedule;
import io.mnsskit.core.SelfTest;
import io.mnsskit.core.Tensor;
import java.io.File;

/**
 * A frame on the device: the plan's GPU steps up to the NPU step, the NPU, the GPU steps after
 * it.  Implements the self-test's {@link SelfTest.Pipeline}; an engine integration drives the
 * same objects with {@link FrameScheduler#next(boolean)} once per frame, its own colour, depth
 * and motion textures in the plan's input resources.
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
    private final GlResources resources;
    private final ComputePasses passes;
    private final NpuRunner npu;
    private final NpuSection.Boundary npuInput;
    private final NpuSection.Boundary npuOutput;
    private final String display;

    GlesPipeline(Manifest manifest, File bundle, NpuRunner.Accelerator accelerator) {
        resources = new GlResources(manifest, bundle);
        passes = new ComputePasses(manifest, bundle);
        npu = new NpuRunner(manifest, bundle, accelerator);
        npuInput = manifest.boundary("npu_input");
        npuOutput = manifest.boundary("npu_output");
        display = outputResource(manifest);
    }

    private static String outputResource(Manifest m) {
        for (GpuSection.Resource r : m.resources) {
            if (r.role.equals("output")) {
                return r.name;
            }
        }
        throw new BundleException("manifest.json: no resource with role 'output'");
    }

    @Override
    public byte[] beforeNpu(FrameScheduler.FramePlan plan, Tensor color, Tensor depth, Tensor motion) {
        resources.uploadTexture(plan.physical("color"), color);
        resources.uploadTexture(plan.physical("depth"), depth);
        resources.uploadTexture(plan.physical("motion"), motion);
        for (FrameScheduler.PlannedStep step : plan.steps) {
            if (step.step.kind == Schedule.Kind.NPU) {
                break;
            }
            passes.dispatch(step, resources);
        }
        return resources.readBuffer(plan.physical(npuInput.bufferResource), npuInput.count());
    }

    @Override
    public byte[] npu(byte[] input) {
        return npu.run(input);
    }

    @Override
    public byte[] afterNpu(FrameScheduler.FramePlan plan, byte[] npuOutputBytes) {
        resources.writeBuffer(plan.physical(npuOutput.bufferResource), npuOutputBytes);
        boolean afterNpu = false;
        for (FrameScheduler.PlannedStep step : plan.steps) {
            if (afterNpu) {
                passes.dispatch(step, resources);
            }
            afterNpu |= step.step.kind == Schedule.Kind.NPU;
        }
        return resources.readRgb8(plan.physical(display));
    }

    @Override
    public void close() {
        npu.close();
        passes.close();
        resources.close();
    }
}
