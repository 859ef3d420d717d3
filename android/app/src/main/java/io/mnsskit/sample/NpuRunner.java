package io.mnsskit.sample;

import io.mnsskit.core.BundleException;
import io.mnsskit.core.GpuFramePipeline;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.NpuSection;
import java.io.File;
import java.io.IOException;
import java.io.RandomAccessFile;
import java.nio.ByteBuffer;
import java.nio.ByteOrder;
import java.nio.MappedByteBuffer;
import java.nio.channels.FileChannel;
import java.util.Arrays;
import java.util.Collections;
import java.util.Map;
import org.tensorflow.lite.DataType;
import org.tensorflow.lite.Delegate;
import org.tensorflow.lite.Interpreter;
import org.tensorflow.lite.Tensor;
import org.tensorflow.lite.gpu.CompatibilityList;
import org.tensorflow.lite.gpu.GpuDelegate;
import org.tensorflow.lite.nnapi.NnApiDelegate;

/**
 * The bundle's {@code npu.tflite} (int8, NHWC) in the LiteRT Interpreter.
 *
 * <p>{@link Accelerator#NNAPI} hands the graph to the vendor's NNAPI driver (the NPU/DSP on most
 * SoCs; NNAPI is deprecated from Android 15, vendors' own LiteRT delegates replace it);
 * {@link Accelerator#GPU} uses the LiteRT GPU delegate; {@link Accelerator#CPU} runs XNNPACK.
 * Drivers may round differently from the desktop kernels the golden frames were computed with:
 * the self-test allows the bundle's tolerance (1 LSB).  Input and output are direct buffers of the
 * tensors' int8 bytes, which are also the packed words of the GPU's SSBOs.  It runs models with
 * one input and one output (checked against the manifest's NPU step).
 */
final class NpuRunner implements GpuFramePipeline.Npu, AutoCloseable {
    /** The LiteRT path: NNAPI delegate, GPU delegate, or the CPU with XNNPACK. */
    enum Accelerator {
        NNAPI("NNAPI delegate"), GPU("LiteRT GPU delegate"), CPU("CPU (XNNPACK)");

        final String label;

        Accelerator(String label) {
            this.label = label;
        }

        /** {@code nnapi}, {@code gpu} or {@code cpu}, in any case. */
        static Accelerator parse(String name) {
            for (Accelerator a : values()) {
                if (a.name().equalsIgnoreCase(name)) {
                    return a;
                }
            }
            throw new IllegalArgumentException("npu must be nnapi, gpu or cpu, not '" + name + "'");
        }
    }

    private final Interpreter interpreter;
    private final Delegate delegate;
    private final ByteBuffer input;
    private final ByteBuffer output;
    private final String outputTensor;

    NpuRunner(Manifest manifest, File bundle, Accelerator accelerator) {
        if (manifest.npu.inputs.size() != 1 || manifest.npu.outputs.size() != 1) {
            throw new BundleException("this app runs NPU models with one input and one output; the manifest lists "
                    + manifest.npu.inputs.size() + " and " + manifest.npu.outputs.size());
        }
        outputTensor = manifest.npu.outputs.get(0);
        Interpreter.Options options = new Interpreter.Options();
        delegate = delegate(accelerator);
        if (delegate != null) {
            options.addDelegate(delegate);
        } else {
            options.setUseXNNPACK(true);
            options.setNumThreads(2);
        }
        interpreter = new Interpreter(map(new File(bundle, manifest.npu.model)), options);
        check(interpreter.getInputTensor(0), manifest.boundary("npu_input"));
        check(interpreter.getOutputTensor(0), manifest.boundary("npu_output"));
        input = ByteBuffer.allocateDirect(manifest.boundary("npu_input").count()).order(ByteOrder.nativeOrder());
        output = ByteBuffer.allocateDirect(manifest.boundary("npu_output").count()).order(ByteOrder.nativeOrder());
    }

    private static Delegate delegate(Accelerator accelerator) {
        switch (accelerator) {
            case NNAPI: {
                NnApiDelegate.Options o = new NnApiDelegate.Options();
                o.setExecutionPreference(NnApiDelegate.Options.EXECUTION_PREFERENCE_SUSTAINED_SPEED);
                o.setAllowFp16(false);     // keep the int8 graph int8
                o.setUseNnapiCpu(false);   // fail over to LiteRT's CPU kernels, not NNAPI's reference CPU
                return new NnApiDelegate(o);
            }
            case GPU: {
                CompatibilityList compatibility = new CompatibilityList();
                if (!compatibility.isDelegateSupportedOnThisDevice()) {
                    throw new IllegalStateException("the LiteRT GPU delegate does not support this device");
                }
                return new GpuDelegate(compatibility.getBestOptionsForThisDevice());
            }
            case CPU:
            default:
                return null;
        }
    }

    /** The interpreter's tensor must be the boundary tensor of the manifest: shape, int8, scale, zero point. */
    private static void check(Tensor tensor, NpuSection.Boundary expected) {
        Tensor.QuantizationParams q = tensor.quantizationParams();
        boolean same = Arrays.equals(tensor.shape(), expected.shape) && tensor.dataType() == DataType.INT8
                && q.getScale() == expected.scale && q.getZeroPoint() == expected.zeroPoint;
        if (!same) {
            throw new BundleException("npu.tflite tensor '" + tensor.name() + "' is " + tensor.dataType() + " " + Arrays.toString(tensor.shape())
                    + " scale " + q.getScale() + " zp " + q.getZeroPoint() + "; manifest.json says int8 " + Arrays.toString(expected.shape)
                    + " scale " + expected.scale + " zp " + expected.zeroPoint);
        }
    }

    /** One inference: int8 NHWC input bytes in, int8 NHWC output bytes out. */
    byte[] run(byte[] in) {
        input.clear();
        input.put(in).rewind();
        output.clear();
        interpreter.run(input, output);
        byte[] out = new byte[output.capacity()];
        output.rewind();
        output.get(out);
        return out;
    }

    /** The frame pipeline's NPU step: the one input tensor's bytes in, the one output tensor's out. */
    @Override
    public Map<String, byte[]> run(Map<String, byte[]> inputs) {
        return Collections.singletonMap(outputTensor, run(inputs.values().iterator().next()));
    }

    private static MappedByteBuffer map(File file) {
        try (RandomAccessFile f = new RandomAccessFile(file, "r"); FileChannel channel = f.getChannel()) {
            return channel.map(FileChannel.MapMode.READ_ONLY, 0, channel.size());
        } catch (IOException e) {
            throw new BundleException(file + ": cannot map (" + e.getMessage() + ")", e);
        }
    }

    @Override
    public void close() {
        interpreter.close();
        if (delegate instanceof AutoCloseable) {
            try {
                ((AutoCloseable) delegate).close();
            } catch (Exception ignored) {
                // closing a delegate releases native memory; nothing to recover
            }
        }
    }
}
