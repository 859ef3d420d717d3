package io.mnsskit.sample;

import io.mnsskit.core.BundleException;
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
 * tensors' int8 bytes, which are also the packed words of the GPU's SSBOs.
 */
final class NpuRunner implements AutoCloseable {
    enum Accelerator { CPU, NNAPI, GPU }

    private final Interpreter interpreter;
    private final Delegate delegate;
    private final ByteBuffer input;
    private final ByteBuffer output;

    NpuRunner(Manifest manifest, File bundle, Accelerator accelerator) {
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
