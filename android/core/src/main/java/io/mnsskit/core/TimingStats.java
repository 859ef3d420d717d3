package io.mnsskit.core;

import java.util.ArrayDeque;
import java.util.ArrayList;
import java.util.Arrays;
import java.util.Deque;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Locale;
import java.util.Map;

/**
 * Per-stage timing over the last {@code window} frames: median and mean milliseconds of every
 * stage and of the whole frame, and frames per second (frames over the summed frame times).
 */
public final class TimingStats {
    private final int window;
    private final List<String> order;
    private final Map<String, Deque<Double>> stages = new LinkedHashMap<>();
    private final Deque<Double> frames = new ArrayDeque<>();

    /** Median and mean of one stage's samples. */
    public static final class Summary {
        public final String stage;
        public final int samples;
        public final double medianMs;
        public final double meanMs;

        Summary(String stage, Deque<Double> values) {
            this.stage = stage;
            double[] v = values.stream().mapToDouble(Double::doubleValue).toArray();
            Arrays.sort(v);
            samples = v.length;
            medianMs = v.length % 2 == 1 ? v[v.length / 2] : (v[v.length / 2 - 1] + v[v.length / 2]) / 2;
            meanMs = Arrays.stream(v).sum() / v.length;
        }
    }

    /** Statistics of the last {@code window} frames; stages named in {@code order} are listed in that order, before any other. */
    public TimingStats(int window, List<String> order) {
        if (window < 1) {
            throw new IllegalArgumentException("window must be at least 1 frame");
        }
        this.window = window;
        this.order = new ArrayList<>(order);
    }

    /** One frame's stages, in milliseconds. */
    public void addStages(Map<String, Double> stageMs) {
        stageMs.forEach((stage, ms) -> push(stages.computeIfAbsent(stage, k -> new ArrayDeque<>()), ms));
    }

    /** One frame's wall time (start of one frame to the start of the next), in milliseconds. */
    public void addFrame(double frameMs) {
        push(frames, frameMs);
    }

    private void push(Deque<Double> values, double ms) {
        values.addLast(ms);
        while (values.size() > window) {
            values.removeFirst();
        }
    }

    /** Every stage seen: those of the given order first, in that order, then the others in the order first seen. */
    public List<Summary> stages() {
        List<Summary> out = new ArrayList<>();
        for (String name : order) {
            if (stages.containsKey(name)) {
                out.add(new Summary(name, stages.get(name)));
            }
        }
        stages.forEach((name, values) -> {
            if (!order.contains(name)) {
                out.add(new Summary(name, values));
            }
        });
        return out;
    }

    /** The whole frame; null before the first frame. */
    public Summary frame() {
        return frames.isEmpty() ? null : new Summary("frame", frames);
    }

    /** Frames per second over the window (0 before the first frame). */
    public double fps() {
        double total = frames.stream().mapToDouble(Double::doubleValue).sum();
        return total > 0 ? frames.size() * 1000.0 / total : 0;
    }

    /** The overlay text: one line per stage (median / mean ms), the frame and the FPS, how the GPU was timed. */
    public String describe(FrameTimer.Source source) {
        StringBuilder out = new StringBuilder();
        for (Summary s : stages()) {
            out.append(String.format(Locale.ROOT, "%-18s %7.2f / %7.2f ms%n", s.stage, s.medianMs, s.meanMs));
        }
        Summary f = frame();
        if (f != null) {
            out.append(String.format(Locale.ROOT, "%-18s %7.2f / %7.2f ms  %.1f FPS%n", "frame", f.medianMs, f.meanMs, fps()));
        }
        int samples = f == null ? 0 : f.samples;
        return out.append("median / mean of the last ").append(samples).append(" frames; GPU steps by ").append(source.label).toString();
    }
}
