package io.mnsskit.sample;

import android.opengl.GLES20;
import android.opengl.GLES30;
import android.opengl.GLES31;
import io.mnsskit.core.BundleException;
import io.mnsskit.core.GpuSection;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.Tensor;
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
 * as ranges.  Uploads and read-backs for the self-test.  Needs a current GL ES 3.1 context.
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

    private final Map<String, Integer> textures = new HashMap<>();
    private final Map<String, Integer> buffers = new HashMap<>();
    private final Map<String, GpuSection.Resource> specs = new HashMap<>();
    private final Map<String, GpuSection.WeightBlock> blocks;
    private final int weights;
    private final int framebuffer;

    static Format format(String name) {
        switch (name) {
            case "rgba16f": return new Format(GLES30.GL_RGBA16F, GLES30.GL_RGBA, 4);
            case "rgba32f": return new Format(GLES30.GL_RGBA32F, GLES30.GL_RGBA, 4);
            case "r32f": return new Format(GLES30.GL_R32F, GLES30.GL_RED, 1);
            case "rg32f": return new Format(GLES30.GL_RG32F, GLES30.GL_RG, 2);
            case "rgba8": return new Format(GLES30.GL_RGBA8, GLES30.GL_RGBA, 4);
            default: throw new BundleException("texture format '" + name + "' is not supported by this app");
        }
    }

    GlResources(Manifest manifest, File bundle) {
        for (GpuSection.Resource r : manifest.resources) {
            specs.put(r.name, r);
            if (r.kind == GpuSection.ResourceKind.BUFFER) {
                buffers.put(r.name, buffer((int) r.bytes, null, GLES30.GL_DYNAMIC_COPY));
            } else {
                textures.put(r.name, texture(r));
            }
        }
        GpuSection.Weights w = manifest.gpu.weights;
        blocks = w.blocks;
        weights = buffer(-1, readDirect(new File(bundle, w.file)), GLES30.GL_STATIC_DRAW);
        int[] fbo = new int[1];
        GLES30.glGenFramebuffers(1, fbo, 0);
        framebuffer = fbo[0];
        checkError("creating resources");
    }

    private static int texture(GpuSection.Resource r) {
        int[] id = new int[1];
        GLES30.glGenTextures(1, id, 0);
        int target = r.kind == GpuSection.ResourceKind.TEXTURE2D_ARRAY ? GLES30.GL_TEXTURE_2D_ARRAY : GLES30.GL_TEXTURE_2D;
        GLES30.glBindTexture(target, id[0]);
        int internal = format(r.format).internal;
        if (target == GLES30.GL_TEXTURE_2D_ARRAY) {
            GLES30.glTexStorage3D(target, 1, internal, r.size[0], r.size[1], r.layers);
        } else {
            GLES30.glTexStorage2D(target, 1, internal, r.size[0], r.size[1]);
        }
        // Shaders read with texelFetch; NEAREST keeps r32f/rg32f (not filterable) texture-complete.
        GLES30.glTexParameteri(target, GLES30.GL_TEXTURE_MIN_FILTER, GLES30.GL_NEAREST);
        GLES30.glTexParameteri(target, GLES30.GL_TEXTURE_MAG_FILTER, GLES30.GL_NEAREST);
        GLES30.glTexParameteri(target, GLES30.GL_TEXTURE_WRAP_S, GLES30.GL_CLAMP_TO_EDGE);
        GLES30.glTexParameteri(target, GLES30.GL_TEXTURE_WRAP_T, GLES30.GL_CLAMP_TO_EDGE);
        return id[0];
    }

    private static int buffer(int bytes, ByteBuffer data, int usage) {
        int[] id = new int[1];
        GLES30.glGenBuffers(1, id, 0);
        GLES30.glBindBuffer(GLES31.GL_SHADER_STORAGE_BUFFER, id[0]);
        GLES30.glBufferData(GLES31.GL_SHADER_STORAGE_BUFFER, data != null ? data.capacity() : bytes, data, usage);
        return id[0];
    }

    void bindSampler(int unit, String name, boolean array) {
        GLES30.glActiveTexture(GLES30.GL_TEXTURE0 + unit);
        GLES30.glBindTexture(array ? GLES30.GL_TEXTURE_2D_ARRAY : GLES30.GL_TEXTURE_2D, texture(name));
    }

    void bindImage(int unit, String name, String declaredFormat, boolean array) {
        // Image bindings in the bundle are the passes' outputs (imageStore, writeonly).
        GLES31.glBindImageTexture(unit, texture(name), 0, array, 0, GLES31.GL_WRITE_ONLY, format(declaredFormat).internal);
    }

    void bindBuffer(int unit, String name) {
        GLES30.glBindBufferBase(GLES31.GL_SHADER_STORAGE_BUFFER, unit, buffer(name));
    }

    /** A weight block as an SSBO range; block offsets are aligned for any GL ES device. */
    void bindWeights(int unit, String block) {
        GpuSection.WeightBlock b = blocks.get(block);
        if (b == null) {
            throw new BundleException("no weight block '" + block + "'");
        }
        GLES30.glBindBufferRange(GLES31.GL_SHADER_STORAGE_BUFFER, unit, weights, (int) b.offset, (int) b.bytes);
    }

    /** Uploads an (h, w, c) float tensor into texture {@code name}, padding missing channels (alpha = 1). */
    void uploadTexture(String name, Tensor t) {
        GpuSection.Resource r = spec(name);
        Format f = format(r.format);
        int w = r.size[0];
        int h = r.size[1];
        int c = t.shape[2];
        if (t.shape[0] != h || t.shape[1] != w || c > f.components) {
            throw new BundleException("tensor " + t.describe() + " does not fit texture '" + name + "' " + w + "x" + h + " " + r.format);
        }
        FloatBuffer data = ByteBuffer.allocateDirect(w * h * f.components * 4).order(ByteOrder.nativeOrder()).asFloatBuffer();
        for (int p = 0; p < w * h; p++) {
            for (int k = 0; k < f.components; k++) {
                data.put(k < c ? t.floatAt(p * c + k) : (k == 3 ? 1.0f : 0.0f));
            }
        }
        data.position(0);
        GLES30.glBindTexture(GLES30.GL_TEXTURE_2D, texture(name));
        GLES30.glPixelStorei(GLES30.GL_UNPACK_ALIGNMENT, 1);
        // float16 values in float32 convert exactly to rgba16f; the rest are float32 already.
        GLES30.glTexSubImage2D(GLES30.GL_TEXTURE_2D, 0, 0, 0, w, h, f.client, GLES30.GL_FLOAT, data);
        checkError("uploading " + name);
    }

    /** Writes raw bytes (an int8 NHWC tensor: its bytes are the packed words) to the start of buffer {@code name}. */
    void writeBuffer(String name, byte[] bytes) {
        ByteBuffer data = ByteBuffer.allocateDirect(bytes.length).order(ByteOrder.LITTLE_ENDIAN);
        data.put(bytes).position(0);
        GLES30.glBindBuffer(GLES31.GL_SHADER_STORAGE_BUFFER, buffer(name));
        GLES30.glBufferSubData(GLES31.GL_SHADER_STORAGE_BUFFER, 0, bytes.length, data);
    }

    /** The first {@code count} bytes of buffer {@code name}, after the shader writes are visible. */
    byte[] readBuffer(String name, int count) {
        GLES31.glMemoryBarrier(GLES31.GL_BUFFER_UPDATE_BARRIER_BIT);
        GLES30.glBindBuffer(GLES31.GL_SHADER_STORAGE_BUFFER, buffer(name));
        ByteBuffer mapped = (ByteBuffer) GLES30.glMapBufferRange(GLES31.GL_SHADER_STORAGE_BUFFER, 0, count, GLES30.GL_MAP_READ_BIT);
        if (mapped == null) {
            throw new IllegalStateException("glMapBufferRange failed on '" + name + "'");
        }
        byte[] out = new byte[count];
        mapped.order(ByteOrder.LITTLE_ENDIAN).get(out);
        GLES30.glUnmapBuffer(GLES31.GL_SHADER_STORAGE_BUFFER);
        return out;
    }

    /** The RGB bytes (H, W, 3), row 0 first, of an rgba8 texture written by imageStore. */
    byte[] readRgb8(String name) {
        GpuSection.Resource r = spec(name);
        int w = r.size[0];
        int h = r.size[1];
        GLES31.glMemoryBarrier(GLES31.GL_FRAMEBUFFER_BARRIER_BIT | GLES31.GL_TEXTURE_UPDATE_BARRIER_BIT);
        GLES30.glBindFramebuffer(GLES30.GL_READ_FRAMEBUFFER, framebuffer);
        GLES30.glFramebufferTexture2D(GLES30.GL_READ_FRAMEBUFFER, GLES30.GL_COLOR_ATTACHMENT0, GLES30.GL_TEXTURE_2D, texture(name), 0);
        ByteBuffer rgba = ByteBuffer.allocateDirect(w * h * 4);
        GLES30.glPixelStorei(GLES30.GL_PACK_ALIGNMENT, 1);
        GLES30.glReadPixels(0, 0, w, h, GLES30.GL_RGBA, GLES30.GL_UNSIGNED_BYTE, rgba);
        GLES30.glBindFramebuffer(GLES30.GL_READ_FRAMEBUFFER, 0);
        checkError("reading " + name);
        byte[] rgb = new byte[w * h * 3];
        for (int p = 0; p < w * h; p++) {
            rgba.position(p * 4);
            rgba.get(rgb, p * 3, 3);
        }
        return rgb;
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

    static void checkError(String what) {
        int error = GLES20.glGetError();
        if (error != GLES20.GL_NO_ERROR) {
            throw new IllegalStateException("GL error 0x" + Integer.toHexString(error) + " while " + what);
        }
    }

    @Override
    public void close() {
        int[] ids = textures.values().stream().mapToInt(Integer::intValue).toArray();
        GLES30.glDeleteTextures(ids.length, ids, 0);
        int[] bufs = buffers.values().stream().mapToInt(Integer::intValue).toArray();
        GLES30.glDeleteBuffers(bufs.length, bufs, 0);
        GLES30.glDeleteBuffers(1, new int[] {weights}, 0);
        GLES30.glDeleteFramebuffers(1, new int[] {framebuffer}, 0);
    }
}
