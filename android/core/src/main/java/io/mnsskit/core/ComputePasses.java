package io.mnsskit.core;

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
    /** What the manifest's barrier rule asks for between GPU steps. */
    private static final int STEP_BARRIERS = Gles31.GL_SHADER_IMAGE_ACCESS_BARRIER_BIT
            | Gles31.GL_TEXTURE_FETCH_BARRIER_BIT | Gles31.GL_SHADER_STORAGE_BARRIER_BIT;

    private static final class Program {
        final int id;
        final Map<String, int[]> uniforms = new HashMap<>(); // name -> {location, GL type}

        Program(int id) {
            this.id = id;
        }
    }

    private final Gles31 gl;
    private final Map<String, Program> programs = new HashMap<>();

    ComputePasses(Gles31 gl, Manifest manifest, File bundle) {
        this.gl = gl;
        for (GpuSection.Pass pass : manifest.gpu.passes.values()) {
            programs.put(pass.name, compile(pass, new File(bundle, pass.file)));
        }
    }

    private Program compile(GpuSection.Pass pass, File file) {
        String source;
        try {
            source = new String(Files.readAllBytes(file.toPath()), StandardCharsets.UTF_8);
        } catch (IOException e) {
            throw new BundleException(file + ": cannot read (" + e.getMessage() + ")", e);
        }
        int shader = gl.glCreateShader(Gles31.GL_COMPUTE_SHADER);
        gl.glShaderSource(shader, source);
        gl.glCompileShader(shader);
        int[] ok = new int[1];
        gl.glGetShaderiv(shader, Gles31.GL_COMPILE_STATUS, ok, 0);
        if (ok[0] == 0) {
            String log = gl.glGetShaderInfoLog(shader);
            gl.glDeleteShader(shader);
            throw new IllegalStateException(pass.file + " does not compile on this GPU:\n" + log);
        }
        int program = gl.glCreateProgram();
        gl.glAttachShader(program, shader);
        gl.glLinkProgram(program);
        gl.glDeleteShader(shader);
        gl.glGetProgramiv(program, Gles31.GL_LINK_STATUS, ok, 0);
        if (ok[0] == 0) {
            throw new IllegalStateException(pass.file + " does not link:\n" + gl.glGetProgramInfoLog(program));
        }
        int[] workgroup = new int[3];
        gl.glGetProgramiv(program, Gles31.GL_COMPUTE_WORK_GROUP_SIZE, workgroup, 0);
        if (workgroup[0] != pass.workgroupSize[0] || workgroup[1] != pass.workgroupSize[1] || workgroup[2] != pass.workgroupSize[2]) {
            throw new BundleException(pass.file + ": local size differs from the manifest's workgroup_size");
        }
        Program p = new Program(program);
        int[] count = new int[1];
        gl.glGetProgramiv(program, Gles31.GL_ACTIVE_UNIFORMS, count, 0);
        int[] size = new int[1];
        int[] type = new int[1];
        for (int i = 0; i < count[0]; i++) {
            String name = gl.glGetActiveUniform(program, i, size, 0, type, 0);
            p.uniforms.put(name, new int[] {gl.glGetUniformLocation(program, name), type[0]});
        }
        return p;
    }

    /** Binds, sets uniforms, dispatches and places the barrier for one GPU step. */
    void dispatch(FrameScheduler.PlannedStep step, GlResources resources) {
        Program program = programs.get(step.pass.name);
        gl.glUseProgram(program.id);
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
        gl.glDispatchCompute(g[0], g[1], g[2]);
        gl.glMemoryBarrier(STEP_BARRIERS);
        resources.checkError(step.step.label);
    }

    private void setUniform(Program program, String name, FrameScheduler.Uniform value) {
        int[] slot = program.uniforms.get(name);
        if (slot == null) {
            return; // not active: the compiler optimised it out
        }
        int location = slot[0];
        switch (slot[1]) {
            case Gles31.GL_INT:
            case Gles31.GL_BOOL:
                gl.glUniform1i(location, value.ints()[0]);
                break;
            case Gles31.GL_INT_VEC2:
                gl.glUniform2i(location, value.ints()[0], value.ints()[1]);
                break;
            case Gles31.GL_FLOAT:
                gl.glUniform1f(location, value.floats()[0]);
                break;
            case Gles31.GL_FLOAT_VEC2:
                gl.glUniform2f(location, value.floats()[0], value.floats()[1]);
                break;
            default:
                throw new BundleException("uniform " + name + " has a GL type (0x" + Integer.toHexString(slot[1]) + ") this app does not set");
        }
    }

    @Override
    public void close() {
        for (Program p : programs.values()) {
            gl.glDeleteProgram(p.id);
        }
    }
}
