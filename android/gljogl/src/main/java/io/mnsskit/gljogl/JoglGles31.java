package io.mnsskit.gljogl;

import com.jogamp.opengl.GL4ES3;
import io.mnsskit.core.Gles31;
import java.nio.Buffer;
import java.nio.ByteBuffer;
import java.nio.charset.StandardCharsets;

/**
 * {@link Gles31} on a desk, over JOGL's {@link GL4ES3} on an OpenGL ES context ({@link JoglContext}).
 * Most calls are the JOGL call of the same name; the ones Android gives String signatures get
 * JOGL's byte-array forms.
 */
public final class JoglGles31 implements Gles31 {
    private static final int LOG_BYTES = 16384;
    private final GL4ES3 gl;

    public JoglGles31(GL4ES3 gl) {
        this.gl = gl;
    }

    @Override public int glGetError() { return gl.glGetError(); }
    @Override public void glGenTextures(int n, int[] textures, int offset) { gl.glGenTextures(n, textures, offset); }
    @Override public void glDeleteTextures(int n, int[] textures, int offset) { gl.glDeleteTextures(n, textures, offset); }
    @Override public void glActiveTexture(int texture) { gl.glActiveTexture(texture); }
    @Override public void glBindTexture(int target, int texture) { gl.glBindTexture(target, texture); }
    @Override public void glTexStorage2D(int target, int levels, int format, int w, int h) { gl.glTexStorage2D(target, levels, format, w, h); }
    @Override public void glTexStorage3D(int target, int levels, int format, int w, int h, int d) { gl.glTexStorage3D(target, levels, format, w, h, d); }
    @Override public void glTexParameteri(int target, int name, int value) { gl.glTexParameteri(target, name, value); }
    @Override public void glPixelStorei(int name, int value) { gl.glPixelStorei(name, value); }
    @Override public void glTexSubImage2D(int target, int level, int x, int y, int w, int h, int format, int type, Buffer pixels) {
        gl.glTexSubImage2D(target, level, x, y, w, h, format, type, pixels);
    }
    @Override public void glTexSubImage3D(int target, int level, int x, int y, int z, int w, int h, int d, int format, int type, Buffer pixels) {
        gl.glTexSubImage3D(target, level, x, y, z, w, h, d, format, type, pixels);
    }
    @Override public void glBindImageTexture(int unit, int texture, int level, boolean layered, int layer, int access, int format) {
        gl.glBindImageTexture(unit, texture, level, layered, layer, access, format);
    }
    @Override public void glGenBuffers(int n, int[] buffers, int offset) { gl.glGenBuffers(n, buffers, offset); }
    @Override public void glDeleteBuffers(int n, int[] buffers, int offset) { gl.glDeleteBuffers(n, buffers, offset); }
    @Override public void glBindBuffer(int target, int buffer) { gl.glBindBuffer(target, buffer); }
    @Override public void glBufferData(int target, int size, Buffer data, int usage) { gl.glBufferData(target, size, data, usage); }
    @Override public void glBufferSubData(int target, int offset, int size, Buffer data) { gl.glBufferSubData(target, offset, size, data); }
    @Override public void glBindBufferBase(int target, int index, int buffer) { gl.glBindBufferBase(target, index, buffer); }
    @Override public void glBindBufferRange(int target, int index, int buffer, int offset, int size) {
        gl.glBindBufferRange(target, index, buffer, offset, size);
    }
    @Override public ByteBuffer glMapBufferRange(int target, int offset, int length, int access) { return gl.glMapBufferRange(target, offset, length, access); }
    @Override public boolean glUnmapBuffer(int target) { return gl.glUnmapBuffer(target); }
    @Override public void glGenFramebuffers(int n, int[] framebuffers, int offset) { gl.glGenFramebuffers(n, framebuffers, offset); }
    @Override public void glDeleteFramebuffers(int n, int[] framebuffers, int offset) { gl.glDeleteFramebuffers(n, framebuffers, offset); }
    @Override public void glBindFramebuffer(int target, int framebuffer) { gl.glBindFramebuffer(target, framebuffer); }
    @Override public void glFramebufferTexture2D(int target, int attachment, int textarget, int texture, int level) {
        gl.glFramebufferTexture2D(target, attachment, textarget, texture, level);
    }
    @Override public void glReadPixels(int x, int y, int w, int h, int format, int type, Buffer pixels) { gl.glReadPixels(x, y, w, h, format, type, pixels); }
    @Override public int glCreateShader(int type) { return gl.glCreateShader(type); }
    @Override public void glShaderSource(int shader, String source) { gl.glShaderSource(shader, 1, new String[] {source}, null, 0); }
    @Override public void glCompileShader(int shader) { gl.glCompileShader(shader); }
    @Override public void glGetShaderiv(int shader, int name, int[] params, int offset) { gl.glGetShaderiv(shader, name, params, offset); }
    @Override public void glDeleteShader(int shader) { gl.glDeleteShader(shader); }
    @Override public int glCreateProgram() { return gl.glCreateProgram(); }
    @Override public void glAttachShader(int program, int shader) { gl.glAttachShader(program, shader); }
    @Override public void glLinkProgram(int program) { gl.glLinkProgram(program); }
    @Override public void glGetProgramiv(int program, int name, int[] params, int offset) { gl.glGetProgramiv(program, name, params, offset); }
    @Override public int glGetUniformLocation(int program, String name) { return gl.glGetUniformLocation(program, name); }
    @Override public void glUseProgram(int program) { gl.glUseProgram(program); }
    @Override public void glDeleteProgram(int program) { gl.glDeleteProgram(program); }
    @Override public void glUniform1i(int location, int x) { gl.glUniform1i(location, x); }
    @Override public void glUniform2i(int location, int x, int y) { gl.glUniform2i(location, x, y); }
    @Override public void glUniform1f(int location, float x) { gl.glUniform1f(location, x); }
    @Override public void glUniform2f(int location, float x, float y) { gl.glUniform2f(location, x, y); }
    @Override public void glDispatchCompute(int x, int y, int z) { gl.glDispatchCompute(x, y, z); }
    @Override public void glMemoryBarrier(int barriers) { gl.glMemoryBarrier(barriers); }
    @Override public String glGetString(int name) { return gl.glGetString(name); }
    @Override public void glGetIntegerv(int name, int[] params, int offset) { gl.glGetIntegerv(name, params, offset); }
    @Override public void glFinish() { gl.glFinish(); }
    @Override public void glGenQueries(int n, int[] ids, int offset) { gl.glGenQueries(n, ids, offset); }
    @Override public void glDeleteQueries(int n, int[] ids, int offset) { gl.glDeleteQueries(n, ids, offset); }
    @Override public void glBeginQuery(int target, int id) { gl.glBeginQuery(target, id); }
    @Override public void glEndQuery(int target) { gl.glEndQuery(target); }
    @Override public void glGetQueryObjectuiv(int id, int name, int[] params, int offset) { gl.glGetQueryObjectuiv(id, name, params, offset); }

    @Override
    public String glGetShaderInfoLog(int shader) {
        return infoLog((size, length, log) -> gl.glGetShaderInfoLog(shader, size, length, 0, log, 0));
    }

    @Override
    public String glGetProgramInfoLog(int program) {
        return infoLog((size, length, log) -> gl.glGetProgramInfoLog(program, size, length, 0, log, 0));
    }

    /** JOGL's info-log calls fill a byte array and its length. */
    private interface InfoLog {
        void read(int size, int[] length, byte[] log);
    }

    private static String infoLog(InfoLog call) {
        byte[] log = new byte[LOG_BYTES];
        int[] length = new int[1];
        call.read(log.length, length, log);
        return new String(log, 0, length[0], StandardCharsets.UTF_8);
    }

    @Override
    public String glGetActiveUniform(int program, int index, int[] size, int sizeOffset, int[] type, int typeOffset) {
        byte[] name = new byte[256];
        int[] length = new int[1];
        gl.glGetActiveUniform(program, index, name.length, length, 0, size, sizeOffset, type, typeOffset, name, 0);
        return new String(name, 0, length[0], StandardCharsets.UTF_8);
    }
}
