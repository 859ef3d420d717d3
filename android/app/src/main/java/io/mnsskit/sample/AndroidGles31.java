package io.mnsskit.sample;

import android.opengl.GLES31;
import io.mnsskit.core.Gles31;
import java.nio.Buffer;
import java.nio.ByteBuffer;

/**
 * {@link Gles31} on the phone: each call is the {@code android.opengl.GLES31} call of the same name
 * (the ES 2.0 and 3.0 ones inherited from GLES20 and GLES30).
 */
final class AndroidGles31 implements Gles31 {
    @Override public int glGetError() { return GLES31.glGetError(); }
    @Override public void glGenTextures(int n, int[] textures, int offset) { GLES31.glGenTextures(n, textures, offset); }
    @Override public void glDeleteTextures(int n, int[] textures, int offset) { GLES31.glDeleteTextures(n, textures, offset); }
    @Override public void glActiveTexture(int texture) { GLES31.glActiveTexture(texture); }
    @Override public void glBindTexture(int target, int texture) { GLES31.glBindTexture(target, texture); }
    @Override public void glTexStorage2D(int target, int levels, int internalFormat, int width, int height) { GLES31.glTexStorage2D(target, levels, internalFormat, width, height); }
    @Override public void glTexStorage3D(int target, int levels, int internalFormat, int width, int height, int depth) { GLES31.glTexStorage3D(target, levels, internalFormat, width, height, depth); }
    @Override public void glTexParameteri(int target, int name, int value) { GLES31.glTexParameteri(target, name, value); }
    @Override public void glPixelStorei(int name, int value) { GLES31.glPixelStorei(name, value); }
    @Override public void glTexSubImage2D(int target, int level, int x, int y, int width, int height, int format, int type, Buffer pixels) { GLES31.glTexSubImage2D(target, level, x, y, width, height, format, type, pixels); }
    @Override public void glTexSubImage3D(int target, int level, int x, int y, int z, int width, int height, int depth, int format, int type, Buffer pixels) { GLES31.glTexSubImage3D(target, level, x, y, z, width, height, depth, format, type, pixels); }
    @Override public void glBindImageTexture(int unit, int texture, int level, boolean layered, int layer, int access, int format) { GLES31.glBindImageTexture(unit, texture, level, layered, layer, access, format); }
    @Override public void glGenBuffers(int n, int[] buffers, int offset) { GLES31.glGenBuffers(n, buffers, offset); }
    @Override public void glDeleteBuffers(int n, int[] buffers, int offset) { GLES31.glDeleteBuffers(n, buffers, offset); }
    @Override public void glBindBuffer(int target, int buffer) { GLES31.glBindBuffer(target, buffer); }
    @Override public void glBufferData(int target, int size, Buffer data, int usage) { GLES31.glBufferData(target, size, data, usage); }
    @Override public void glBufferSubData(int target, int offset, int size, Buffer data) { GLES31.glBufferSubData(target, offset, size, data); }
    @Override public void glBindBufferBase(int target, int index, int buffer) { GLES31.glBindBufferBase(target, index, buffer); }
    @Override public void glBindBufferRange(int target, int index, int buffer, int offset, int size) { GLES31.glBindBufferRange(target, index, buffer, offset, size); }
    @Override public ByteBuffer glMapBufferRange(int target, int offset, int length, int access) { return (ByteBuffer) GLES31.glMapBufferRange(target, offset, length, access); }
    @Override public boolean glUnmapBuffer(int target) { return GLES31.glUnmapBuffer(target); }
    @Override public void glGenFramebuffers(int n, int[] framebuffers, int offset) { GLES31.glGenFramebuffers(n, framebuffers, offset); }
    @Override public void glDeleteFramebuffers(int n, int[] framebuffers, int offset) { GLES31.glDeleteFramebuffers(n, framebuffers, offset); }
    @Override public void glBindFramebuffer(int target, int framebuffer) { GLES31.glBindFramebuffer(target, framebuffer); }
    @Override public void glFramebufferTexture2D(int target, int attachment, int textarget, int texture, int level) { GLES31.glFramebufferTexture2D(target, attachment, textarget, texture, level); }
    @Override public void glReadPixels(int x, int y, int width, int height, int format, int type, Buffer pixels) { GLES31.glReadPixels(x, y, width, height, format, type, pixels); }
    @Override public int glCreateShader(int type) { return GLES31.glCreateShader(type); }
    @Override public void glShaderSource(int shader, String source) { GLES31.glShaderSource(shader, source); }
    @Override public void glCompileShader(int shader) { GLES31.glCompileShader(shader); }
    @Override public void glGetShaderiv(int shader, int name, int[] params, int offset) { GLES31.glGetShaderiv(shader, name, params, offset); }
    @Override public String glGetShaderInfoLog(int shader) { return GLES31.glGetShaderInfoLog(shader); }
    @Override public void glDeleteShader(int shader) { GLES31.glDeleteShader(shader); }
    @Override public int glCreateProgram() { return GLES31.glCreateProgram(); }
    @Override public void glAttachShader(int program, int shader) { GLES31.glAttachShader(program, shader); }
    @Override public void glLinkProgram(int program) { GLES31.glLinkProgram(program); }
    @Override public void glGetProgramiv(int program, int name, int[] params, int offset) { GLES31.glGetProgramiv(program, name, params, offset); }
    @Override public String glGetProgramInfoLog(int program) { return GLES31.glGetProgramInfoLog(program); }
    @Override public String glGetActiveUniform(int program, int index, int[] size, int sizeOffset, int[] type, int typeOffset) { return GLES31.glGetActiveUniform(program, index, size, sizeOffset, type, typeOffset); }
    @Override public int glGetUniformLocation(int program, String name) { return GLES31.glGetUniformLocation(program, name); }
    @Override public void glUseProgram(int program) { GLES31.glUseProgram(program); }
    @Override public void glDeleteProgram(int program) { GLES31.glDeleteProgram(program); }
    @Override public void glUniform1i(int location, int x) { GLES31.glUniform1i(location, x); }
    @Override public void glUniform2i(int location, int x, int y) { GLES31.glUniform2i(location, x, y); }
    @Override public void glUniform1f(int location, float x) { GLES31.glUniform1f(location, x); }
    @Override public void glUniform2f(int location, float x, float y) { GLES31.glUniform2f(location, x, y); }
    @Override public void glDispatchCompute(int x, int y, int z) { GLES31.glDispatchCompute(x, y, z); }
    @Override public void glMemoryBarrier(int barriers) { GLES31.glMemoryBarrier(barriers); }
    @Override public String glGetString(int name) { return GLES31.glGetString(name); }
    @Override public void glGetIntegerv(int name, int[] params, int offset) { GLES31.glGetIntegerv(name, params, offset); }
    @Override public void glFinish() { GLES31.glFinish(); }
    @Override public void glGenQueries(int n, int[] ids, int offset) { GLES31.glGenQueries(n, ids, offset); }
    @Override public void glDeleteQueries(int n, int[] ids, int offset) { GLES31.glDeleteQueries(n, ids, offset); }
    @Override public void glBeginQuery(int target, int id) { GLES31.glBeginQuery(target, id); }
    @Override public void glEndQuery(int target) { GLES31.glEndQuery(target); }
    @Override public void glGetQueryObjectuiv(int id, int name, int[] params, int offset) { GLES31.glGetQueryObjectuiv(id, name, params, offset); }
}
