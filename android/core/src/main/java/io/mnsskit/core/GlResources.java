package io.mnsskit.core;

import java.io.File;
import java.io.IOException;
import java.nio.ByteBuffer;
import java.nio.ByteOrder;
import java.nio.FloatBuffer;
import java.nio.file.Files;
import java.util.HashMap;
import java.util.Map;

/**
 * The textures and buffers of a bundle's {@code resources}, created once from the manifest
 * (sizes, formats, layers, buffer bytes), and the weight file as one SSBO whose blocks are bound
 * as ranges.  Uploads and read-backs for the self-test.  Needs a current GL ES 3.1 context
 * (every call goes through {@link Gles31}).
 */
final class GlResources implements AutoCloseable {
    /** A GL sized format and the client format used to upload float data to it. */
    static final class Format {
        final int internal;
        final int client;
        final int components;

        Format(int internal, int client, int components) {
            this.internal = internal;
            this.client = client;
            this.components = components;
        }
    }

    private final Gles31 gl;
    private final Map<String, Integer> textures = new HashMap<>();
    private final Map<String, Integer> buffers = new HashMap<>();
    private final Map<String, GpuSection.Resource> specs = new HashMap<>();
    private final Map<String, GpuSection.WeightBlock> blocks;
    private final int weights;
    private final int framebuffer;

    static Format format(String name) {
        switch (name) {
            case "rgba16f": return new Format(Gles31.GL_RGBA16F, Gles31.GL_RGBA, 4);
            case "rgba32f": return new Format(Gles31.GL_RGBA32F, Gles31.GL_RGBA, 4);
            case "r32f": return new Format(Gles31.GL_R32F, Gles31.GL_RED, 1);
            case "rg32f": return new Format(Gles31.GL_RG32F, Gles31.GL_RG, 2);
            case "rgba8": return new Format(Gles31.GL_RGBA8, Gles31.GL_RGBA, 4);
            default: throw new BundleException("texture format '" + name + "' is not supported by this app");
        }
    }

    GlResources(Gles31 gl, Manifest manifest, File bundle) {
        this.gl = gl;
        for (GpuSection.Resource r : manifest.resources) {
            specs.put(r.name, r);
            if (r.kind == GpuSection.ResourceKind.BUFFER) {
                buffers.put(r.name, buffer((int) r.bytes, null, Gles31.GL_DYNAMIC_COPY));
            } else {
                textures.put(r.name, texture(r));
            }
        }
        GpuSection.Weights w = manifest.gpu.weights;
        blocks = w.blocks;
        weights = buffer(-1, readDirect(new File(bundle, w.file)), Gles31.GL_STATIC_DRAW);
        int[] fbo = new int[1];
        gl.glGenFramebuffers(1, fbo, 0);
        framebuffer = fbo[0];
        checkError("creating resources");
    }

    private int texture(GpuSection.Resource r) {
        int[] id = new int[1];
        gl.glGenTextures(1, id, 0);
        int target = r.kind == GpuSection.ResourceKind.TEXTURE2D_ARRAY ? Gles31.GL_TEXTURE_2D_ARRAY : Gles31.GL_TEXTURE_2D;
        gl.glBindTexture(target, id[0]);
        int internal = format(r.format).internal;
        if (target == Gles31.GL_TEXTURE_2D_ARRAY) {
            gl.glTexStorage3D(target, 1, internal, r.size[0], r.size[1], r.layers);
        } else {
            gl.glTexStorage2D(target, 1, internal, r.size[0], r.size[1]);
        }
        // Shaders read with texelFetch; NEAREST keeps r32f/rg32f (not filterable) texture-complete.
        gl.glTexParameteri(target, Gles31.GL_TEXTURE_MIN_FILTER, Gles31.GL_NEAREST);
        gl.glTexParameteri(target, Gles31.GL_TEXTURE_MAG_FILTER, Gles31.GL_NEAREST);
        gl.glTexParameteri(target, Gles31.GL_TEXTURE_WRAP_S, Gles31.GL_CLAMP_TO_EDGE);
        gl.glTexParameteri(target, Gles31.GL_TEXTURE_WRAP_T, Gles31.GL_CLAMP_TO_EDGE);
        return id[0];
    }

    private int buffer(int bytes, ByteBuffer data, int usage) {
        int[] id = new int[1];
        gl.glGenBuffers(1, id, 0);
        gl.glBindBuffer(Gles31.GL_SHADER_STORAGE_BUFFER, id[0]);
        gl.glBufferData(Gles31.GL_SHADER_STORAGE_BUFFER, data != null ? data.capacity() : bytes, data, usage);
        return id[0];
    }

    void bindSampler(int unit, String name, boolean array) {
        gl.glActiveTexture(Gles31.GL_TEXTURE0 + unit);
        gl.glBindTexture(array ? Gles31.GL_TEXTURE_2D_ARRAY : Gles31.GL_TEXTURE_2D, texture(name));
    }

    void bindImage(int unit, String name, String declaredFormat, boolean array) {
        // Image bindings in the bundle are the passes' outputs (imageStore, writeonly).
        gl.glBindImageTexture(unit, texture(name), 0, array, 0, Gles31.GL_WRITE_ONLY, format(declaredFormat).internal);
    }

    void bindBuffer(int unit, String name) {
        gl.glBindBufferBase(Gles31.GL_SHADER_STORAGE_BUFFER, unit, buffer(name));
    }

    /** A weight block as an SSBO range; block offsets are aligned for any GL ES device. */
    void bindWeights(int unit, String block) {
        GpuSection.WeightBlock b = blocks.get(block);
        if (b == null) {
            throw new BundleException("no weight block '" + block + "'");
        }
        gl.glBindBufferRange(Gles31.GL_SHADER_STORAGE_BUFFER, unit, weights, (int) b.offset, (int) b.bytes);
    }

    /**
     * Uploads an (h, w, c) float tensor into texture {@code name}, as the desktop's GPU passes
     * (mnss_kit/gpu/mesa.py) fill it: a 2D texture pads missing channels with 0 (alpha with 1); a
     * 2D array holds channels {@code 4l .. 4l+3} in layer {@code l}, zero padded.
     */
    void uploadTexture(String name, Tensor t) {
        GpuSection.Resource r = spec(name);
        Format f = format(r.format);
        boolean array = r.kind == GpuSection.ResourceKind.TEXTURE2D_ARRAY;
        int w = r.size[0];
        int h = r.size[1];
        int c = t.shape[2];
        int layers = array ? r.layers : 1;
        int channels = layers * f.components;
        if (t.shape[0] != h || t.shape[1] != w || c > channels) {
            throw new BundleException("tensor " + t.describe() + " does not fit texture '" + name + "' " + w + "x" + h + " " + r.format
                    + (array ? " x" + layers + " layers" : ""));
        }
        FloatBuffer data = ByteBuffer.allocateDirect(w * h * channels * 4).order(ByteOrder.nativeOrder()).asFloatBuffer();
        for (int l = 0; l < layers; l++) {
            for (int p = 0; p < w * h; p++) {
                for (int k = 0; k < f.components; k++) {
                    int channel = l * f.components + k;
                    data.put(channel < c ? t.floatAt(p * c + channel) : (!array && k == 3 ? 1.0f : 0.0f));
                }
            }
        }
        data.position(0);
        int target = array ? Gles31.GL_TEXTURE_2D_ARRAY : Gles31.GL_TEXTURE_2D;
        gl.glBindTexture(target, texture(name));
        gl.glPixelStorei(Gles31.GL_UNPACK_ALIGNMENT, 1);
        // float16 values in float32 convert exactly to rgba16f; the rest are float32 already.
        if (array) {
            gl.glTexSubImage3D(target, 0, 0, 0, 0, w, h, layers, f.client, Gles31.GL_FLOAT, data);
        } else {
            gl.glTexSubImage2D(target, 0, 0, 0, w, h, f.client, Gles31.GL_FLOAT, data);
        }
        checkError("uploading " + name);
    }

    /** Writes raw bytes (an int8 NHWC tensor: its bytes are the packed words) to the start of buffer {@code name}. */
    void writeBuffer(String name, byte[] bytes) {
        ByteBuffer data = ByteBuffer.allocateDirect(bytes.length).order(ByteOrder.LITTLE_ENDIAN);
        data.put(bytes).position(0);
        gl.glBindBuffer(Gles31.GL_SHADER_STORAGE_BUFFER, buffer(name));
        gl.glBufferSubData(Gles31.GL_SHADER_STORAGE_BUFFER, 0, bytes.length, data);
    }

    /** The first {@code count} bytes of buffer {@code name}, after the shader writes are visible. */
    byte[] readBuffer(String name, int count) {
        gl.glMemoryBarrier(Gles31.GL_BUFFER_UPDATE_BARRIER_BIT);
        gl.glBindBuffer(Gles31.GL_SHADER_STORAGE_BUFFER, buffer(name));
        ByteBuffer mapped = gl.glMapBufferRange(Gles31.GL_SHADER_STORAGE_BUFFER, 0, count, Gles31.GL_MAP_READ_BIT);
        if (mapped == null) {
            throw new IllegalStateException("glMapBufferRange failed on '" + name + "'");
        }
        byte[] out = new byte[count];
        mapped.order(ByteOrder.LITTLE_ENDIAN).get(out);
        gl.glUnmapBuffer(Gles31.GL_SHADER_STORAGE_BUFFER);
        return out;
    }

    /** The RGB bytes (H, W, 3), row 0 first, of an rgba8 texture written by imageStore. */
    byte[] readRgb8(String name) {
        GpuSection.Resource r = spec(name);
        int w = r.size[0];
        int h = r.size[1];
        ByteBuffer rgba = readPixels(name, Gles31.GL_UNSIGNED_BYTE, 4);
        byte[] rgb = new byte[w * h * 3];
        for (int p = 0; p < w * h; p++) {
            rgba.position(p * 4);
            rgba.get(rgb, p * 3, 3);
        }
        return rgb;
    }

    /**
     * The values of 2D float texture {@code name}, {@code (h, w, channels)} float32 with the
     * manifest's channel count, row 0 first (RGBA / FLOAT read-back, which ES allows for float
     * colour buffers: EXT_color_buffer_float).
     */
    float[] readFloats(String name) {
        GpuSection.Resource r = spec(name);
        Format f = format(r.format);
        if (r.kind != GpuSection.ResourceKind.TEXTURE2D || f.internal == Gles31.GL_RGBA8) {
            throw new BundleException("resource '" + name + "' is not a 2D float texture");
        }
        int w = r.size[0];
        int h = r.size[1];
        int channels = r.channels == 0 ? f.components : r.channels;
        FloatBuffer rgba = readPixels(name, Gles31.GL_FLOAT, 16).asFloatBuffer();
        float[] out = new float[w * h * channels];
        for (int p = 0; p < w * h; p++) {
            for (int k = 0; k < channels; k++) {
                out[p * channels + k] = rgba.get(p * 4 + k);
            }
        }
        return out;
    }

    /** RGBA pixels of 2D texture {@code name} read as {@code type} ({@code bytesPerPixel} each), after the shader writes are visible. */
    private ByteBuffer readPixels(String name, int type, int bytesPerPixel) {
        GpuSection.Resource r = spec(name);
        gl.glMemoryBarrier(Gles31.GL_FRAMEBUFFER_BARRIER_BIT | Gles31.GL_TEXTURE_UPDATE_BARRIER_BIT);
        gl.glBindFramebuffer(Gles31.GL_READ_FRAMEBUFFER, framebuffer);
        gl.glFramebufferTexture2D(Gles31.GL_READ_FRAMEBUFFER, Gles31.GL_COLOR_ATTACHMENT0, Gles31.GL_TEXTURE_2D, texture(name), 0);
        ByteBuffer pixels = ByteBuffer.allocateDirect(r.size[0] * r.size[1] * bytesPerPixel).order(ByteOrder.nativeOrder());
        gl.glPixelStorei(Gles31.GL_PACK_ALIGNMENT, 1);
        gl.glReadPixels(0, 0, r.size[0], r.size[1], Gles31.GL_RGBA, type, pixels);
        gl.glBindFramebuffer(Gles31.GL_READ_FRAMEBUFFER, 0);
        checkError("reading " + name);
        return pixels;
    }

    private int texture(String name) {
        Integer id = textures.get(name);
        if (id == null) {
            throw new BundleException("no texture resource '" + name + "'");
        }
        return id;
    }

    private int buffer(String name) {
        Integer id = buffers.get(name);
        if (id == null) {
            throw new BundleException("no buffer resource '" + name + "'");
        }
        return id;
    }

    private GpuSection.Resource spec(String name) {
        GpuSection.Resource r = specs.get(name);
        if (r == null) {
            throw new BundleException("no resource '" + name + "'");
        }
        return r;
    }

    private static ByteBuffer readDirect(File file) {
        try {
            byte[] bytes = Files.readAllBytes(file.toPath());
            ByteBuffer out = ByteBuffer.allocateDirect(bytes.length).order(ByteOrder.LITTLE_ENDIAN);
            out.put(bytes).position(0);
            return out;
        } catch (IOException e) {
            throw new BundleException(file + ": cannot read (" + e.getMessage() + ")", e);
        }
    }

    void checkError(String what) {
        int error = gl.glGetError();
        if (error != Gles31.GL_NO_ERROR) {
            throw new IllegalStateException("GL error 0x" + Integer.toHexString(error) + " while " + what);
        }
    }

    @Override
    public void close() {
        int[] ids = textures.values().stream().mapToInt(Integer::intValue).toArray();
        gl.glDeleteTextures(ids.length, ids, 0);
        int[] bufs = buffers.values().stream().mapToInt(Integer::intValue).toArray();
        gl.glDeleteBuffers(bufs.length, bufs, 0);
        gl.glDeleteBuffers(1, new int[] {weights}, 0);
        gl.glDeleteFramebuffers(1, new int[] {framebuffer}, 0);
    }
}
