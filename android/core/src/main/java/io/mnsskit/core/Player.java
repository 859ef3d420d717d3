package io.mnsskit.core;

import java.io.File;
import java.util.ArrayList;
import java.util.List;
import java.util.Map;

/**
 * Plays a bundle's recorded sequence ({@code export --sequence}) in a loop through the frame
 * pipeline: per frame the scheduler's plan with the jitter and reset flag the frame was recorded
 * with (frame 0 again after the last: a cut), the inputs uploaded, the GPU steps, the NPU (the
 * caller's {@link GpuFramePipeline.Npu}), the output read back; every stage timed
 * ({@link FrameTimer}, {@link TimingStats}).  For the last frame it gives the bilinear upscale of
 * the same LR colour and the manifest's debug views, at the output's size.  Needs the GL context
 * current on the calling thread, as the pipeline does.
 */
public final class Player implements AutoCloseable {
    /** Frames the timing statistics cover. */
    public static final int STATS_WINDOW = 120;
    /** The input resource holding the LR colour (the toolkit's frame key). */
    public static final String COLOUR_INPUT = "color";

    private final Manifest manifest;
    private final Sequence.Loaded sequence;
    private final FrameScheduler scheduler;
    private final GpuFramePipeline pipeline;
    private final FrameTimer timer;
    private final TimingStats stats;
    private long played;
    private long lastStart = -1;
    private Frame last;

    /** The frame just played. */
    public static final class Frame {
        /** Frame of the recorded sequence (0 .. frame_count - 1). */
        public final int index;
        public final boolean reset;
        /** The output resource's codes, {@code (H, W, 3)}. */
        public final byte[] output;
        /** Milliseconds by stage. */
        public final Map<String, Double> ms;
        final FrameScheduler.FramePlan plan;
        final Map<String, Tensor> inputs;
        final Manifest.JitterEntry jitter;

        Frame(int index, FrameScheduler.FramePlan plan, Map<String, Tensor> inputs, byte[] output, Map<String, Double> ms) {
            this.index = index;
            this.reset = plan.reset;
            this.plan = plan;
            this.inputs = inputs;
            this.jitter = plan.jitter;
            this.output = output;
            this.ms = ms;
        }
    }

    /**
     * Decompresses the sequence, allocates the resources and compiles the passes.
     * {@code timerQueries}: time GPU steps with timer queries when the driver has them.
     */
    public Player(Gles31 gl, Manifest manifest, File bundle, GpuFramePipeline.Npu npu, boolean timerQueries) {
        if (manifest.sequence == null) {
            throw new BundleException(bundle + ": the bundle carries no recorded sequence (export it with --sequence DIR --frames N)");
        }
        if (!manifest.sequence.arrays.containsKey(COLOUR_INPUT)) {
            throw new BundleException(bundle + ": the recorded sequence has no '" + COLOUR_INPUT + "' input to upscale bilinearly");
        }
        this.manifest = manifest;
        sequence = manifest.sequence.load(bundle);
        scheduler = new FrameScheduler(manifest);
        pipeline = new GpuFramePipeline(gl, manifest, bundle, npu);
        timer = new FrameTimer(gl, timerQueries);
        pipeline.timeWith(timer);
        List<String> order = new ArrayList<>();
        for (Schedule.Step step : manifest.schedule.steps) {
            order.add(step.kind == Schedule.Kind.NPU ? GpuFramePipeline.npuStage(step) : step.label);
        }
        stats = new TimingStats(STATS_WINDOW, order);
    }

    /** Plays the next frame of the loop. */
    public Frame next() {
        long start = System.nanoTime();
        if (lastStart >= 0) {
            stats.addFrame((start - lastStart) / 1e6);
        }
        lastStart = start;
        int index = (int) (played % manifest.sequence.frames.size());
        Sequence.Frame recorded = manifest.sequence.frames.get(index);
        FrameScheduler.FramePlan plan = scheduler.plan(recorded.jitter, recorded.reset || index == 0);
        Map<String, Tensor> inputs = sequence.frame(index);
        byte[] output = pipeline.frame(plan, inputs);
        Map<String, Double> ms = timer.endFrame();
        stats.addStages(ms);
        played++;
        last = new Frame(index, plan, inputs, output, ms);
        return last;
    }

    /** The output's width and height. */
    public int[] outputSize() {
        return manifest.resource(manifest.golden.output).size.clone();
    }

    /** The bilinear upscale of the last frame's LR colour at its jitter, {@code (H, W, 3)} codes. */
    public byte[] bilinear() {
        return Bilinear.displayCodes(played().inputs.get(COLOUR_INPUT), manifest.hrSize[0], manifest.hrSize[1], last.jitter);
    }

    /** Debug view {@code view} of the last frame, {@code (H, W, 3)} codes at the output's size (nearest). */
    public byte[] debugView(DebugView view) {
        Frame frame = played();
        GpuSection.Resource r = manifest.resource(view.resource);
        Tensor input = frame.inputs.get(view.resource);
        float[] values;
        if (input != null) {
            values = new float[input.count()];
            for (int i = 0; i < values.length; i++) {
                values[i] = input.floatAt(i);
            }
        } else {
            values = pipeline.readFloats(frame.plan, view.resource);
        }
        int w = r.size[0];
        int h = r.size[1];
        byte[] codes = view.render(values, values.length / (w * h), w, h, frame.reset);
        int[] out = outputSize();
        if (out[0] % w != 0 || out[1] % h != 0) {
            throw new BundleException("debug view '" + view.name + "': " + w + "x" + h + " does not divide the output's " + out[0] + "x" + out[1]);
        }
        return Compositor.nearest(codes, w, h, out[0] / w, out[1] / h);
    }

    private Frame played() {
        if (last == null) {
            throw new IllegalStateException("no frame played yet");
        }
        return last;
    }

    public TimingStats stats() {
        return stats;
    }

    /** How the GPU steps are timed. */
    public FrameTimer.Source timing() {
        return timer.source;
    }

    @Override
    public void close() {
        timer.close();
        pipeline.close();
    }
}
