package io.mnsskit.sample;

import android.opengl.GLES20;
import android.opengl.GLES30;
import android.opengl.GLES31;
import android.util.Log;
import io.mnsskit.core.BundleException;
import io.mnsskit.core.FrameScheduler;
import io.mnsskit.core.GpuSection;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.Schedule;
import java.io.File;
import java.io.IOException;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.util.HashMap;
import java.util.Map;

/**
 * The bundle's compute shaders, compiled from its files, and the dispatch of one planned step:
 * every binding and workgroup count comes from the manifest, every uniform value from the
 * {@link FrameScheduler}; the GL type of each uniform is asked from the linked program.
 */
final class ComputePasses implements AutoCloseable {
    private static final String TAG = "mnss-kit";
    /** What the manifest's barrier rule asks for between GPU steps. */
    private static final int STEP_BARRIERS = GLES31.GL_SHADER_IMAGE_ACCESS_BARRIER_BIT
            | GLES31.GL_TEXTURE_FETCH_BARRIER_BIT | GLES31.GL_SHADER_STORAGE_BARRIER_BIT;

    private static final class Program {
        final int id;
        final Map<String, int[]> uniforms = new HashMap<>(); // name -> {location, GL type}

        Program(int id) {
            this.id = id;
        }
    }

    private final Map<String, Program> programs = new HashMap<>();

    ComputePasses(Manifest manifest, File bundle) {
        for (GpuSection.Pass pass : manifest.gpu.passes.values()) {
            programs.put(pass.name, compile(pass, new File(bundle, pass.file)));
        }
    }

    private static Program compile(GpuSection.Pass pass, File file) {
        String source;
        try {
            source = new String(Files.readAllBytes(file.toPath()), StandardCharsets.UTF_8);
        } catch (IOException e) {
            throw new BundleException(file + ": cannot read (" + e.getMessage() + ")", e);
        }
        int shader = GLES20.glCreateShader(GLES31.GL_COMPUTE_SHADER);
        GLES20.glShaderSource(shader, source);
        GLES20.glCompileShader(shader);
        int[] ok = new int[1];
        GLES20.glGetShaderiv(shader, GLES20.GL_COMPILE_STATUS, ok, 0);
        if (ok[0] == 0) {
            String log = GLES20.glGetShaderInfoLog(shader);
            GLES20.glDeleteShader(shader);
            throw new IllegalStateException(pass.file + " does not compile on this GPU:\n" + log);
        }
        int program = GLES20.glCreateProgram();
        GLES20.glAttachShader(program, shader);
        GLES20.glLinkProgram(program);
        GLES20.glDeleteShader(shader);
        GLES20.glGetProgramiv(program, GLES20.GL_LINK_STATUS, ok, 0);
        if (ok[0] == 0) {
            throw new IllegalStateException(pass.file + " does not link:\n" + GLES20.glGetProgramInfoLog(program));
        }
        int[] workgroup = new int[3];
        GLES31.glGetProgramiv(program, GLES31.GL_COMPUTE_WORK_GROUP_SIZE, workgroup, 0);
        if (workgroup[0] != pass.workgroupSize[0] || workgroup[1] != pass.workgroupSize[1] || workgroup[2] != pass.workgroupSize[2]) {
            throw new BundleException(pass.file + ": local size differs from the manifest's workgroup_size");
        }
        Program p = new Program(program);
        int[] count = new int[1];
        GLES20.glGetProgramiv(program, GLES20.GL_ACTIVE_UNIFORMS, count, 0);
        int[] size = new int[1];
        int[] type = new int[1];
        for (int i = 0; i < count[0]; i++) {
            String name = GLES20.glGetActiveUniform(program, i, size, 0, type, 0);
            p.uniforms.put(name, new int[] {GLES20.glGetUniformLocation(program, name), type[0]});
        }
        return p;
    }

    /** Binds, sets uniforms, dispatches and places the barrier for one GPU step. */
    void dispatch(FrameScheduler.PlannedStep step, GlResources resources) {
        Program program = programs.get(step.pass.name);
        GLES20.glUseProgram(program.id);
        for (GpuSection.Binding b : step.pass.bindings.values()) {
            String target = step.bind.get(b.name);
            switch (b.kind) {
                case SAMPLER:
                    resources.bindSampler(b.unit, target, b.array);
                    break;
                case IMAGE:
                    resources.bindImage(b.unit, target, b.format, b.array);
                    break;
                case BUFFER:
                    if (target.startsWith(Schedule.WEIGHTS_PREFIX)) {
                        resources.bindWeights(b.unit, target.substring(Schedule.WEIGHTS_PREFIX.length()));
                    } else {
                        resources.bindBuffer(b.unit, target);
                    }
                    break;
                default:
                    throw new IllegalStateException("binding kind " + b.kind);
            }
        }
        for (Map.Entry<String, FrameScheduler.Uniform> u : step.uniforms.entrySet()) {
            setUniform(program, u.getKey(), u.getValue());
        }
        int[] g = step.step.groups;
        GLES31.glDispatchCompute(g[0], g[1], g[2]);
        GLES31.glMemoryBarrier(STEP_BARRIERS);
        GlResources.checkError(step.step.label);
    }

    private static void setUniform(Program program, String name, FrameScheduler.Uniform value) {
        int[] slot = program.uniforms.get(name);
        if (slot == null) {
            Log.d(TAG, "uniform " + name + " is not active (optimised out); skipped");
            return;
        }
        int location = slot[0];
        switch (slot[1]) {
            case GLES20.GL_INT:
            case GLES20.GL_BOOL:
                GLES20.glUniform1i(location, value.ints()[0]);
                break;
            case GLES20.GL_INT_VEC2:
                GLES20.glUniform2i(location, value.ints()[0], value.ints()[1]);
                break;
            case GLES20.GL_FLOAT:
                GLES20.glUniform1f(location, value.floats()[0]);
                break;
            case GLES20.GL_FLOAT_VEC2:
                GLES20.glUniform2f(location, value.floats()[0], value.floats()[1]);
                break;
            default:
                throw new BundleException("uniform " + name + " has a GL type (0x" + Integer.toHexString(slot[1]) + ") this app does not set");
        }
    }

    @Override
    public void close() {
        for (Program p : programs.values()) {
            GLES30.glDeleteProgram(p.id);
        }
    }
}
