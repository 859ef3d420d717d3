package io.mnsskit.core;

import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.function.Supplier;

/**
 * Milliseconds per stage of one frame: GPU steps with GL timer queries where the driver has them
 * (GL_EXT_disjoint_timer_query: the GPU's own time for the step), otherwise the wall time between
 * a {@code glFinish} before and after the step (which also counts the driver's submission and the
 * CPU-GPU round trip, so it reads higher); CPU work (the NPU call) with the system clock.  Stages
 * of the same label in one frame add up.
 */
public final class FrameTimer implements AutoCloseable {
    public enum Source {
        TIMER_QUERY("GL timer queries"),
        FINISH_CLOCK("glFinish + System.nanoTime");

        public final String label;

        Source(String label) {
            this.label = label;
        }
    }

    private final Gles31 gl;
    public final Source source;
    private final List<Integer> pool = new ArrayList<>();
    private final List<String> pendingLabels = new ArrayList<>();
    private final Map<String, Double> frame = new LinkedHashMap<>();
    /** Stage labels in the order they first ran this frame. */
    private final List<String> order = new ArrayList<>();
    private String open;
    private long openedAt;

    /** Timer queries when {@code useQueries} and the driver has them; needs a current context. */
    public FrameTimer(Gles31 gl, boolean useQueries) {
        this.gl = gl;
        source = useQueries && gl.hasTimerQuery() ? Source.TIMER_QUERY : Source.FINISH_CLOCK;
    }

    /** Starts timing GPU step {@code label}; one step at a time. */
    public void gpuBegin(String label) {
        if (open != null) {
            throw new IllegalStateException("GPU step '" + open + "' is still being timed");
        }
        open = label;
        started(label);
        if (source == Source.TIMER_QUERY) {
            int index = pendingLabels.size();
            if (index == pool.size()) {
                int[] id = new int[1];
                gl.glGenQueries(1, id, 0);
                pool.add(id[0]);
            }
            pendingLabels.add(label);
            gl.glBeginQuery(Gles31.GL_TIME_ELAPSED_EXT, pool.get(index));
        } else {
            gl.glFinish();
            openedAt = System.nanoTime();
        }
    }

    public void gpuEnd() {
        if (source == Source.TIMER_QUERY) {
            gl.glEndQuery(Gles31.GL_TIME_ELAPSED_EXT);
        } else {
            gl.glFinish();
            add(open, (System.nanoTime() - openedAt) / 1e6);
        }
        open = null;
    }

    /** Runs {@code work} and records its wall time as stage {@code label}. */
    public <T> T cpu(String label, Supplier<T> work) {
        started(label);
        long start = System.nanoTime();
        T result = work.get();
        add(label, (System.nanoTime() - start) / 1e6);
        return result;
    }

    /**
     * The frame's milliseconds by stage, in the order they ran; resets for the next frame.  Waits
     * for the queries' results.  When the GPU reports a disjoint event (frequency change, context
     * loss) the frame's GPU times are meaningless and left out.
     */
    public Map<String, Double> endFrame() {
        if (source == Source.TIMER_QUERY && !pendingLabels.isEmpty()) {
            int[] nanos = new int[1];
            Map<String, Double> gpu = new LinkedHashMap<>();
            for (int i = 0; i < pendingLabels.size(); i++) {
                gl.glGetQueryObjectuiv(pool.get(i), Gles31.GL_QUERY_RESULT, nanos, 0);
                gpu.merge(pendingLabels.get(i), Integer.toUnsignedLong(nanos[0]) / 1e6, Double::sum);
            }
            int[] disjoint = new int[1];
            gl.glGetIntegerv(Gles31.GL_GPU_DISJOINT_EXT, disjoint, 0);
            if (disjoint[0] == 0) {
                gpu.forEach(this::add);
            } else {
                order.removeAll(gpu.keySet());
            }
            pendingLabels.clear();
        }
        Map<String, Double> out = new LinkedHashMap<>();
        for (String label : order) {
            out.put(label, frame.get(label));
        }
        frame.clear();
        order.clear();
        return out;
    }

    private void add(String label, double ms) {
        frame.merge(label, ms, Double::sum);
    }

    private void started(String label) {
        if (!order.contains(label)) {
            order.add(label);
        }
    }

    @Override
    public void close() {
        int[] ids = pool.stream().mapToInt(Integer::intValue).toArray();
        if (ids.length > 0) {
            gl.glDeleteQueries(ids.length, ids, 0);
        }
        pool.clear();
    }
}
