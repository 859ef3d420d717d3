import com.jogamp.opengl.GL;
import com.jogamp.opengl.GL2ES2;
import com.jogamp.opengl.GL2ES3;
import com.jogamp.opengl.GL3ES3;
import com.jogamp.opengl.GL4ES3;
import io.mnsskit.gljogl.JoglContext;
import java.nio.ByteBuffer;
import java.nio.ByteOrder;
import java.nio.FloatBuffer;
import java.nio.IntBuffer;

/**
 * Whether JOGL gets an OpenGL ES 3.2 context on this machine (Mesa llvmpipe, no display) and
 * runs what the app's frame pipeline needs through {@link GL4ES3}: a compute shader writing an
 * SSBO and {@code imageStore} into RGBA16F and R32UI textures, {@code glMemoryBarrier}, and
 * read-back with {@code glMapBufferRange} and {@code glReadPixels}.  Prints the context's
 * version and renderer, then {@code checked N wrong M gl_error E}; exits 1 if anything is off.
 *
 * <p>Run with {@code EGL_PLATFORM=surfaceless} and {@code -Djogl.disable.opengldesktop}
 * ({@link JoglContext} says why).
 */
public final class GlesProbe {
    private static final int N = 4;
    private static final String SHADER = "#version 310 es\n"
            + "layout(local_size_x = 4, local_size_y = 4) in;\n"
            + "layout(std430, binding = 0) buffer Words { uint v[]; } words;\n"
            + "layout(rgba16f, binding = 0) writeonly uniform highp image2D halfImage;\n"
            + "layout(r32ui, binding = 1) writeonly uniform highp uimage2D uintImage;\n"
            + "void main() {\n"
            + "  ivec2 p = ivec2(gl_GlobalInvocationID.xy);\n"
            + "  uint i = uint(p.y * 4 + p.x);\n"
            + "  words.v[i] = i * 3u + 1u;\n"
            + "  imageStore(halfImage, p, vec4(float(i) * 0.5, 0.25, -1.0, 1.0));\n"
            + "  imageStore(uintImage, p, uvec4(i + 100u));\n"
            + "}\n";

    private GlesProbe() {
    }

    public static void main(String[] args) {
        int wrong;
        int error;
        try (JoglContext context = new JoglContext()) {
            GL4ES3 gl = context.gl();
            System.out.println("version " + gl.glGetString(GL.GL_VERSION) + " | renderer " + gl.glGetString(GL.GL_RENDERER));
            wrong = run(gl);
            error = gl.glGetError();
        }
        System.out.println("checked " + 3 * N * N + " wrong " + wrong + " gl_error " + error);
        System.exit(wrong == 0 && error == GL.GL_NO_ERROR ? 0 : 1);
    }

    private static int run(GL4ES3 gl) {
        gl.glUseProgram(program(gl));
        int[] ids = new int[3];
        gl.glGenBuffers(1, ids, 0);
        gl.glBindBuffer(GL4ES3.GL_SHADER_STORAGE_BUFFER, ids[0]);
        gl.glBufferData(GL4ES3.GL_SHADER_STORAGE_BUFFER, N * N * 4, null, GL2ES2.GL_DYNAMIC_DRAW);
        gl.glBindBufferBase(GL4ES3.GL_SHADER_STORAGE_BUFFER, 0, ids[0]);
        gl.glGenTextures(2, ids, 1);
        image(gl, ids[1], 0, GL.GL_RGBA16F);
        image(gl, ids[2], 1, GL2ES3.GL_R32UI);
        gl.glDispatchCompute(1, 1, 1);
        gl.glMemoryBarrier((int) GL3ES3.GL_ALL_BARRIER_BITS);
        int wrong = 0;
        ByteBuffer words = gl.glMapBufferRange(GL4ES3.GL_SHADER_STORAGE_BUFFER, 0, N * N * 4, GL.GL_MAP_READ_BIT).order(ByteOrder.nativeOrder());
        for (int i = 0; i < N * N; i++) {
            wrong += words.getInt(i * 4) == i * 3 + 1 ? 0 : 1;
        }
        gl.glUnmapBuffer(GL4ES3.GL_SHADER_STORAGE_BUFFER);
        int[] framebuffer = new int[1];
        gl.glGenFramebuffers(1, framebuffer, 0);
        gl.glBindFramebuffer(GL.GL_FRAMEBUFFER, framebuffer[0]);
        gl.glFramebufferTexture2D(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0, GL.GL_TEXTURE_2D, ids[1], 0);
        FloatBuffer halves = ByteBuffer.allocateDirect(N * N * 16).order(ByteOrder.nativeOrder()).asFloatBuffer();
        gl.glReadPixels(0, 0, N, N, GL.GL_RGBA, GL.GL_FLOAT, halves);
        for (int i = 0; i < N * N; i++) {
            wrong += halves.get(i * 4) == i * 0.5f && halves.get(i * 4 + 1) == 0.25f && halves.get(i * 4 + 2) == -1f ? 0 : 1;
        }
        gl.glFramebufferTexture2D(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0, GL.GL_TEXTURE_2D, ids[2], 0);
        IntBuffer uints = ByteBuffer.allocateDirect(N * N * 16).order(ByteOrder.nativeOrder()).asIntBuffer();
        gl.glReadPixels(0, 0, N, N, GL2ES3.GL_RGBA_INTEGER, GL.GL_UNSIGNED_INT, uints);
        for (int i = 0; i < N * N; i++) {
            wrong += uints.get(i * 4) == i + 100 ? 0 : 1;
        }
        return wrong;
    }

    private static void image(GL4ES3 gl, int texture, int unit, int format) {
        gl.glBindTexture(GL.GL_TEXTURE_2D, texture);
        gl.glTexStorage2D(GL.GL_TEXTURE_2D, 1, format, N, N);
        gl.glBindImageTexture(unit, texture, 0, false, 0, GL2ES3.GL_WRITE_ONLY, format);
    }

    private static int program(GL4ES3 gl) {
        int shader = gl.glCreateShader(GL3ES3.GL_COMPUTE_SHADER);
        gl.glShaderSource(shader, 1, new String[] {SHADER}, null);
        gl.glCompileShader(shader);
        int[] status = new int[1];
        gl.glGetShaderiv(shader, GL2ES2.GL_COMPILE_STATUS, status, 0);
        if (status[0] == 0) {
            byte[] log = new byte[4096];
            int[] length = new int[1];
            gl.glGetShaderInfoLog(shader, log.length, length, 0, log, 0);
            throw new IllegalStateException("compute shader: " + new String(log, 0, length[0]));
        }
        int program = gl.glCreateProgram();
        gl.glAttachShader(program, shader);
        gl.glLinkProgram(program);
        gl.glGetProgramiv(program, GL2ES2.GL_LINK_STATUS, status, 0);
        if (status[0] == 0) {
            throw new IllegalStateException("compute program does not link");
        }
        return program;
    }
}
