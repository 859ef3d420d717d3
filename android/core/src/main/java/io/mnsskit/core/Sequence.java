package io.mnsskit.core;

import java.io.File;
import java.io.IOException;
import java.nio.file.Files;
import java.util.ArrayList;
import java.util.Arrays;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.zip.DataFormatException;
import java.util.zip.Inflater;

/**
 * The recorded input sequence a bundle may carry ({@code mnss-kit export --sequence}), for the
 * app to play in a loop: per {@code input} resource one zlib stream ({@link Inflater}) of all
 * frames, shape {@code (frames, h, w, channels)}, dtype as the golden frames give it; per frame
 * the reset flag and the jitter it was rendered with ({@code mnss_kit/export/sequence.py}).
 */
public final class Sequence {
    public final String source;
    public final List<Frame> frames;
    /** Input resource name to its stored array, in manifest order. */
    public final Map<String, Array> arrays;

    public static final class Frame {
        public final int index;
        public final boolean reset;
        public final Manifest.JitterEntry jitter;

        Frame(Json j) {
            index = j.get("index").asInt();
            reset = j.get("reset").asBool();
            float[] offset = Manifest.pair(j.get("jitter")).asFloatArray();
            int[] sub = Manifest.pair(j.get("subpixel")).asIntArray();
            Json ji = j.get("jitter_index");
            jitter = new Manifest.JitterEntry(ji.isNull() ? -1 : ji.asInt(), offset[0], offset[1], sub[0], sub[1]);
        }
    }

    public static final class Array {
        public final String file;
        public final Tensor.DType dtype;
        /** {@code (frames, h, w, channels)}. */
        public final int[] shape;
        /** Uncompressed size. */
        public final long bytes;

        Array(Json j) {
            file = j.get("file").asString();
            dtype = Tensor.DType.of(j.get("dtype").asString());
            shape = Manifest.shape(j.get("shape"));
            bytes = j.get("bytes").asLong();
            String compression = j.get("compression").asString();
            if (!compression.equals("zlib")) {
                throw new BundleException(j.path() + " compression '" + compression + "' is not zlib");
            }
            if (shape.length != 4 || bytes != Tensor.count(shape) * dtype.size) {
                throw new BundleException(j.path() + " " + bytes + " bytes do not hold " + dtype.id + " " + Arrays.toString(shape)
                        + " (frames, h, w, channels)");
            }
        }
    }

    /** The section {@code j} of a manifest whose resources are {@code resources}; every input resource must be there. */
    Sequence(Json j, List<GpuSection.Resource> resources) {
        source = j.get("source").asString();
        int count = j.get("frame_count").asInt();
        List<Frame> list = new ArrayList<>();
        for (Json f : j.get("frames").items()) {
            list.add(new Frame(f));
        }
        if (list.size() != count) {
            throw new BundleException(j.path() + " lists " + list.size() + " frames for frame_count " + count);
        }
        frames = Collections.unmodifiableList(list);
        Json aj = j.get("arrays");
        Map<String, Array> map = new LinkedHashMap<>();
        for (GpuSection.Resource r : resources) {
            if (!r.role.equals("input")) {
                continue;
            }
            if (!aj.has(r.name)) {
                throw new BundleException(aj.path() + " missing input resource '" + r.name + "'");
            }
            Array a = new Array(aj.get(r.name));
            int channels = r.channels == 0 ? a.shape[3] : r.channels;
            int[] expected = {count, r.size[1], r.size[0], channels};
            if (!Arrays.equals(a.shape, expected) || a.dtype != Golden.FORMAT_DTYPES.get(r.format)) {
                throw new BundleException(aj.get(r.name).path() + " is " + a.dtype.id + " " + Arrays.toString(a.shape) + "; resource '"
                        + r.name + "' needs " + Golden.FORMAT_DTYPES.get(r.format).id + " " + Arrays.toString(expected));
            }
            map.put(r.name, a);
        }
        arrays = Collections.unmodifiableMap(map);
    }

    /** Every array decompressed once, to be played frame by frame. */
    public Loaded load(File bundle) {
        Map<String, byte[]> data = new LinkedHashMap<>();
        arrays.forEach((name, a) -> data.put(name, inflate(new File(bundle, a.file), a.bytes)));
        return new Loaded(data);
    }

    /** The decompressed sequence. */
    public final class Loaded {
        private final Map<String, byte[]> data;

        Loaded(Map<String, byte[]> data) {
            this.data = data;
        }

        /** Frame {@code t}'s inputs, by resource name: (h, w, channels) tensors as the golden frames hold them. */
        public Map<String, Tensor> frame(int t) {
            if (t < 0 || t >= frames.size()) {
                throw new IndexOutOfBoundsException("frame " + t + " of a " + frames.size() + "-frame sequence");
            }
            Map<String, Tensor> out = new LinkedHashMap<>();
            arrays.forEach((name, a) -> {
                int[] shape = {a.shape[1], a.shape[2], a.shape[3]};
                int size = (int) (Tensor.count(shape) * a.dtype.size);
                out.put(name, new Tensor(name, a.dtype, shape, null, 0, Arrays.copyOfRange(data.get(name), t * size, (t + 1) * size)));
            });
            return out;
        }
    }

    private static byte[] inflate(File file, long bytes) {
        byte[] compressed;
        try {
            compressed = Files.readAllBytes(file.toPath());
        } catch (IOException e) {
            throw new BundleException(file + ": cannot read (" + e.getMessage() + ")", e);
        }
        if (bytes > Integer.MAX_VALUE) {
            throw new BundleException(file + ": " + bytes + " bytes uncompressed is more than this app holds");
        }
        Inflater inflater = new Inflater();
        try {
            inflater.setInput(compressed);
            byte[] out = new byte[(int) bytes];
            int n = 0;
            while (n < out.length && !inflater.finished()) {
                int got = inflater.inflate(out, n, out.length - n);
                if (got == 0 && (inflater.needsInput() || inflater.needsDictionary())) {
                    break;
                }
                n += got;
            }
            if (n != out.length || !inflater.finished()) {
                throw new BundleException(file + ": does not decompress to the " + bytes + " bytes the manifest states");
            }
            return out;
        } catch (DataFormatException e) {
            throw new BundleException(file + ": not a zlib stream (" + e.getMessage() + ")", e);
        } finally {
            inflater.end();
        }
    }
}
