package io.mnsskit.core;

import java.nio.Buffer;
import java.nio.ByteBuffer;

/**
 * The OpenGL ES 3.1 calls the frame pipeline makes, and nothing more, so the same pipeline
 * classes ({@link GlResources}, {@link ComputePasses}, {@link GpuFramePipeline}) run on a phone
 * (the app's {@code AndroidGles31}, over {@code android.opengl.GLES31}) and on a desk (JOGL's
 * {@code GL4ES3}, android/gljogl).  Signatures follow {@code android.opengl}; the constants are
 * the Khronos enum values, the same in every binding.  All calls need a current context.
 */
public interface Gles31 {
    int GL_NO_ERROR = 0;
    int GL_FLOAT = 0x1406;
    int GL_INT = 0x1404;
    int GL_UNSIGNED_BYTE = 0x1401;
    int GL_BOOL = 0x8B56;
    int GL_INT_VEC2 = 0x8B53;
    int GL_FLOAT_VEC2 = 0x8B50;
    int GL_RED = 0x1903;
    int GL_RG = 0x8227;
    int GL_RGBA = 0x1908;
    int GL_RGBA8 = 0x8058;
    int GL_RGBA16F = 0x881A;
    int GL_RGBA32F = 0x8814;
    int GL_R32F = 0x822E;
    int GL_RG32F = 0x8230;
    int GL_TEXTURE_2D = 0x0DE1;
    int GL_TEXTURE_2D_ARRAY = 0x8C1A;
    int GL_TEXTURE0 = 0x84C0;
    int GL_TEXTURE_MIN_FILTER = 0x2801;
    int GL_TEXTURE_MAG_FILTER = 0x2800;
    int GL_TEXTURE_WRAP_S = 0x2802;
    int GL_TEXTURE_WRAP_T = 0x2803;
    int GL_NEAREST = 0x2600;
    int GL_CLAMP_TO_EDGE = 0x812F;
    int GL_UNPACK_ALIGNMENT = 0x0CF5;
    int GL_PACK_ALIGNMENT = 0x0D05;
    int GL_SHADER_STORAGE_BUFFER = 0x90D2;
    int GL_STATIC_DRAW = 0x88E4;
    int GL_DYNAMIC_COPY = 0x88EA;
    int GL_MAP_READ_BIT = 0x0001;
    int GL_READ_FRAMEBUFFER = 0x8CA8;
    int GL_COLOR_ATTACHMENT0 = 0x8CE0;
    int GL_WRITE_ONLY = 0x88B9;
    int GL_COMPUTE_SHADER = 0x91B9;
    int GL_COMPILE_STATUS = 0x8B81;
    int GL_LINK_STATUS = 0x8B82;
    int GL_ACTIVE_UNIFORMS = 0x8B86;
    int GL_COMPUTE_WORK_GROUP_SIZE = 0x8267;
    int GL_SHADER_IMAGE_ACCESS_BARRIER_BIT = 0x00000020;
    int GL_TEXTURE_FETCH_BARRIER_BIT = 0x00000008;
    int GL_SHADER_STORAGE_BARRIER_BIT = 0x00002000;
    int GL_BUFFER_UPDATE_BARRIER_BIT = 0x00000200;
    int GL_TEXTURE_UPDATE_BARRIER_BIT = 0x00000100;
    int GL_FRAMEBUFFER_BARRIER_BIT = 0x00000400;
    int GL_EXTENSIONS = 0x1F03;
    int GL_RENDERER = 0x1F01;
    int GL_VERSION = 0x1F02;
    // GL_EXT_disjoint_timer_query
    int GL_TIME_ELAPSED_EXT = 0x88BF;
    int GL_GPU_DISJOINT_EXT = 0x8FBB;
    int GL_QUERY_RESULT = 0x8866;
    String TIMER_QUERY_EXTENSION = "GL_EXT_disjoint_timer_query";

    int glGetError();

    // textures
    void glGenTextures(int n, int[] textures, int offset);
    void glDeleteTextures(int n, int[] textures, int offset);
    void glActiveTexture(int texture);
    void glBindTexture(int target, int texture);
    void glTexStorage2D(int target, int levels, int internalFormat, int width, int height);
    void glTexStorage3D(int target, int levels, int internalFormat, int width, int height, int depth);
    void glTexParameteri(int target, int name, int value);
    void glPixelStorei(int name, int value);
    void glTexSubImage2D(int target, int level, int x, int y, int width, int height, int format, int type, Buffer pixels);
    void glTexSubImage3D(int target, int level, int x, int y, int z, int width, int height, int depth, int format, int type, Buffer pixels);
    void glBindImageTexture(int unit, int texture, int level, boolean layered, int layer, int access, int format);

    // buffers
    void glGenBuffers(int n, int[] buffers, int offset);
    void glDeleteBuffers(int n, int[] buffers, int offset);
    void glBindBuffer(int target, int buffer);
    void glBufferData(int target, int size, Buffer data, int usage);
    void glBufferSubData(int target, int offset, int size, Buffer data);
    void glBindBufferBase(int target, int index, int buffer);
    void glBindBufferRange(int target, int index, int buffer, int offset, int size);
    /** The mapped range, or null if the driver refuses. */
    ByteBuffer glMapBufferRange(int target, int offset, int length, int access);
    boolean glUnmapBuffer(int target);

    // read-back (ES has no glGetTexImage)
    void glGenFramebuffers(int n, int[] framebuffers, int offset);
    void glDeleteFramebuffers(int n, int[] framebuffers, int offset);
    void glBindFramebuffer(int target, int framebuffer);
    void glFramebufferTexture2D(int target, int attachment, int textarget, int texture, int level);
    void glReadPixels(int x, int y, int width, int height, int format, int type, Buffer pixels);

    // programs
    int glCreateShader(int type);
    void glShaderSource(int shader, String source);
    void glCompileShader(int shader);
    void glGetShaderiv(int shader, int name, int[] params, int offset);
    String glGetShaderInfoLog(int shader);
    void glDeleteShader(int shader);
    int glCreateProgram();
    void glAttachShader(int program, int shader);
    void glLinkProgram(int program);
    void glGetProgramiv(int program, int name, int[] params, int offset);
    String glGetProgramInfoLog(int program);
    /** The active uniform's name; its size and GL type go to {@code size[sizeOffset]} and {@code type[typeOffset]}. */
    String glGetActiveUniform(int program, int index, int[] size, int sizeOffset, int[] type, int typeOffset);
    int glGetUniformLocation(int program, String name);
    void glUseProgram(int program);
    void glDeleteProgram(int program);
    void glUniform1i(int location, int x);
    void glUniform2i(int location, int x, int y);
    void glUniform1f(int location, float x);
    void glUniform2f(int location, float x, float y);

    // compute
    void glDispatchCompute(int x, int y, int z);
    void glMemoryBarrier(int barriers);

    // timing: GPU time with GL_EXT_disjoint_timer_query's GL_TIME_ELAPSED_EXT target of the ES 3.0
    // query calls (32-bit results: nanoseconds, enough for one pass); wall time around glFinish otherwise
    String glGetString(int name);
    void glGetIntegerv(int name, int[] params, int offset);
    void glFinish();
    void glGenQueries(int n, int[] ids, int offset);
    void glDeleteQueries(int n, int[] ids, int offset);
    void glBeginQuery(int target, int id);
    void glEndQuery(int target);
    void glGetQueryObjectuiv(int id, int name, int[] params, int offset);

    /** Whether the driver has GPU timer queries (GL_EXT_disjoint_timer_query). */
    default boolean hasTimerQuery() {
        String extensions = glGetString(GL_EXTENSIONS);
        return extensions != null && java.util.Arrays.asList(extensions.split(" ")).contains(TIMER_QUERY_EXTENSION);
    }
}
