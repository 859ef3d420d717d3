package io.mnsskit.sample;

import io.mnsskit.core.FrameScheduler;
import io.mnsskit.core.GpuFramePipeline;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.SelfTest;
import io.mnsskit.core.Tensor;
import java.io.File;
import java.util.List;
import java.util.Map;

/**
 * A frame on the device: the core's {@link GpuFramePipeline} over {@link AndroidGles31} with
 * LiteRT ({@link NpuRunner}) as its NPU step.  An engine integration drives the same objects with
 * {@link FrameScheduler#next(boolean)} once per frame, its own textures in the plan's input
 * resources (whatever the manifest lists as {@code input}).
 *
 * <p>The GPU -> NPU handoff is a copy (see {@link GpuFramePipeline}).  A shipping integration
 * shares the memory instead: an AHardwareBuffer (BLOB format, usage GPU_DATA_BUFFER |
 * CPU_READ/WRITE as the driver needs) imported into GL with eglGetNativeClientBufferANDROID +
 * glBufferStorageExternalEXT (GL_EXT_external_buffer) as the SSBO, and into the NPU as
 * ANeuralNetworksMemory_createFromAHardwareBuffer (NNAPI) or a LiteRT TensorBuffer created from
 * the AHardwareBuffer; the GPU's writes are handed over with an EGL native fence
 * (EGL_ANDROID_native_fence_sync) instead of glFinish.  That path needs the NDK and is described
 * in android/README.md; the numerics do not change.
 */
final class GlesPipeline implements SelfTest.Pipeline, AutoCloseable {
    private final NpuRunner npu;
    private final GpuFramePipeline gpu;

    GlesPipeline(Manifest manifest, File bundle, NpuRunner.Accelerator accelerator) {
        npu = new NpuRunner(manifest, bundle, accelerator);
        gpu = new GpuFramePipeline(new AndroidGles31(), manifest, bundle, npu);
    }

    @Override
    public Map<String, byte[]> beforeNpu(FrameScheduler.FramePlan plan, Map<String, Tensor> inputs, List<String> npuInputs) {
        return gpu.beforeNpu(plan, inputs, npuInputs);
    }

    @Override
    public Map<String, byte[]> npu(Map<String, byte[]> inputs) {
        return gpu.npu(inputs);
    }

    @Override
    public byte[] afterNpu(FrameScheduler.FramePlan plan, Map<String, byte[]> npuOutputs, String output) {
        return gpu.afterNpu(plan, npuOutputs, output);
    }

    @Override
    public void close() {
        gpu.close();
        npu.close();
    }
}
