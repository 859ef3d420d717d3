package io.mnsskit.core;

import static org.junit.Assert.assertArrayEquals;
import static org.junit.Assert.assertEquals;
import static org.junit.Assert.assertNull;
import static org.junit.Assert.assertThrows;
import static org.junit.Assert.assertTrue;

import java.lang.reflect.InvocationHandler;
import java.lang.reflect.Proxy;
import java.util.ArrayList;
import java.util.Arrays;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import org.junit.Test;

/** The playback logic that needs no GL: timing statistics, the frame timer's two sources, debug-view colours, composition. */
public class PlaybackTest {
    private static Map<String, Double> stages(Object... labelsAndMs) {
        Map<String, Double> out = new LinkedHashMap<>();
        for (int i = 0; i < labelsAndMs.length; i += 2) {
            out.put((String) labelsAndMs[i], ((Number) labelsAndMs[i + 1]).doubleValue());
        }
        return out;
    }

    @Test
    public void statisticsGiveMedianMeanAndFpsOverTheWindow() {
        TimingStats stats = new TimingStats(3, Arrays.asList("warp", "NPU net"));
        stats.addStages(stages("NPU net", 9, "warp", 1));
        stats.addStages(stages("NPU net", 3, "warp", 2, "extra", 5));
        stats.addStages(stages("NPU net", 6, "warp", 10));
        stats.addStages(stages("NPU net", 4, "warp", 4)); // the window drops the first frame
        for (double ms : new double[] {100, 20, 20, 40}) {
            stats.addFrame(ms);
        }
        List<TimingStats.Summary> s = stats.stages();
        assertEquals(Arrays.asList("warp", "NPU net", "extra"), Arrays.asList(s.get(0).stage, s.get(1).stage, s.get(2).stage));
        assertEquals(4.0, s.get(0).medianMs, 0); // {2, 10, 4}
        assertEquals(16.0 / 3, s.get(0).meanMs, 1e-12);
        assertEquals(4.0, s.get(1).medianMs, 0); // {3, 6, 4}
        assertEquals(1, s.get(2).samples);
        assertEquals(20.0, stats.frame().medianMs, 0); // {20, 20, 40}
        assertEquals(3 * 1000.0 / 80, stats.fps(), 1e-12);
        String text = stats.describe(FrameTimer.Source.FINISH_CLOCK);
        assertTrue(text, text.contains("37.5 FPS") && text.endsWith("last 3 frames; GPU steps by glFinish + System.nanoTime"));
    }

    @Test
    public void evenSampleCountsTakeTheMeanOfTheMiddleTwo() {
        TimingStats stats = new TimingStats(10, Collections.emptyList());
        stats.addStages(stages("a", 1));
        stats.addStages(stages("a", 7));
        assertEquals(4.0, stats.stages().get(0).medianMs, 0);
        assertNull(stats.frame());
        assertEquals(0.0, stats.fps(), 0);
        assertThrows(IllegalArgumentException.class, () -> new TimingStats(0, Collections.emptyList()));
    }

    /** A Gles31 that answers only the calls a FrameTimer makes, and records them. */
    private static Gles31 fakeGl(String extensions, int nanos, int disjoint, List<String> calls) {
        InvocationHandler handler = (proxy, method, args) -> {
            if (method.isDefault()) {
                return InvocationHandler.invokeDefault(proxy, method, args);
            }
            calls.add(method.getName());
            switch (method.getName()) {
                case "glGetString":
                    return extensions;
                case "glGetQueryObjectuiv":
                    ((int[]) args[2])[0] = nanos;
                    return null;
                case "glGetIntegerv":
                    ((int[]) args[1])[0] = disjoint;
                    return null;
                case "glGenQueries":
                    ((int[]) args[1])[0] = 1 + (int) calls.stream().filter("glGenQueries"::equals).count();
                    return null;
                default:
                    return null;
            }
        };
        return (Gles31) Proxy.newProxyInstance(Gles31.class.getClassLoader(), new Class<?>[] {Gles31.class}, handler);
    }

    @Test
    public void timerQueriesGiveTheGpusTimeInTheOrderTheStagesRan() {
        List<String> calls = new ArrayList<>();
        FrameTimer timer = new FrameTimer(fakeGl("GL_OES_x GL_EXT_disjoint_timer_query", 2_500_000, 0, calls), true);
        assertEquals(FrameTimer.Source.TIMER_QUERY, timer.source);
        for (int frame = 0; frame < 2; frame++) {
            timer.gpuBegin("a");
            timer.gpuEnd();
            assertEquals("x", timer.cpu("npu", () -> "x"));
            timer.gpuBegin("b");
            timer.gpuEnd();
            timer.gpuBegin("a");
            timer.gpuEnd();
            Map<String, Double> ms = timer.endFrame();
            assertEquals(Arrays.asList("a", "npu", "b"), new ArrayList<>(ms.keySet()));
            assertEquals(5.0, ms.get("a"), 1e-12); // two steps of one label add up
            assertEquals(2.5, ms.get("b"), 1e-12);
        }
        assertEquals(3, calls.stream().filter("glGenQueries"::equals).count()); // queries are reused from frame to frame
        assertTrue(!calls.contains("glFinish"));
        timer.close();
        assertTrue(calls.contains("glDeleteQueries"));
    }

    @Test
    public void aDisjointFrameDropsItsGpuTimes() {
        FrameTimer timer = new FrameTimer(fakeGl("GL_EXT_disjoint_timer_query", 1_000_000, 1, new ArrayList<>()), true);
        timer.gpuBegin("a");
        timer.gpuEnd();
        timer.cpu("npu", () -> 0);
        assertEquals(Collections.singletonList("npu"), new ArrayList<>(timer.endFrame().keySet()));
    }

    @Test
    public void withoutTheExtensionStepsAreTimedAroundGlFinish() {
        List<String> calls = new ArrayList<>();
        FrameTimer timer = new FrameTimer(fakeGl("GL_EXT_disjoint_timer_query_webgl2 GL_OES_x", 0, 0, calls), true);
        assertEquals(FrameTimer.Source.FINISH_CLOCK, timer.source);
        timer.gpuBegin("a");
        timer.gpuEnd();
        assertThrows(IllegalStateException.class, () -> {
            timer.gpuBegin("b");
            timer.gpuBegin("c");
        });
        assertEquals(Arrays.asList("glGetString", "glFinish", "glFinish", "glFinish"), calls);
        assertEquals(FrameTimer.Source.FINISH_CLOCK, new FrameTimer(fakeGl("GL_EXT_disjoint_timer_query", 0, 0, calls), false).source);
    }

    private static DebugView view(String json) {
        return new DebugView(Json.parse(json, "view.json"));
    }

    @Test
    public void scalarViewsRunFromBlackToWhiteOverTheirRange() {
        DebugView v = view("{\"name\": \"w\", \"resource\": \"r\", \"map\": \"scalar\", \"range\": [0.5, 1.5], \"description\": \"\"}");
        byte[] rgb = v.render(new float[] {0.0f, 0.5f, 1.0f, 2.0f}, 1, 2, 2, false);
        assertArrayEquals(new byte[] {0, 0, 0, 0, 0, 0, (byte) 128, (byte) 128, (byte) 128, (byte) 255, (byte) 255, (byte) 255}, rgb);
    }

    @Test
    public void masksMarkValuesBelowTheThresholdAndNothingOnAReset() {
        DebugView v = view("{\"name\": \"h\", \"resource\": \"r\", \"map\": \"mask\", \"below\": 0.5, \"on_reset\": 1.0, \"description\": \"\"}");
        float[] values = {0.1f, 0.5f, 0.49f};
        byte[] marked = {(byte) 255, (byte) 128, 0};
        assertArrayEquals(new byte[] {marked[0], marked[1], marked[2], 0, 0, 0, marked[0], marked[1], marked[2]}, v.render(values, 1, 3, 1, false));
        assertArrayEquals(new byte[9], v.render(values, 1, 3, 1, true));
    }

    @Test
    public void vectorsAreColouredByDirectionAndLength() {
        DebugView v = view("{\"name\": \"m\", \"resource\": \"r\", \"map\": \"vector\", \"range\": [0, 4], \"description\": \"\"}");
        assertArrayEquals(new int[] {255, 255, 255}, v.colour(0, 0)); // no motion: white
        assertArrayEquals(new int[] {255, 0, 0}, v.colour(4, 0)); // right, full length: red
        assertArrayEquals(new int[] {255, 128, 128}, v.colour(2, 0)); // half length: half saturated
        assertArrayEquals(new int[] {0, 255, 255}, v.colour(-8, 0)); // left, beyond the range: cyan
        assertArrayEquals(new int[] {128, 255, 0}, v.colour(0, 4)); // down (+y): 90 degrees
        assertArrayEquals(new int[] {128, 0, 255}, v.colour(0, -4)); // up: 270 degrees
        assertThrows(IllegalArgumentException.class, () -> v.render(new float[4], 1, 2, 2, false));
    }

    @Test
    public void viewsAreCheckedWhenRead() {
        BundleException e = assertThrows(BundleException.class,
                () -> view("{\"name\": \"w\", \"resource\": \"r\", \"map\": \"scalar\", \"range\": [1, 1], \"description\": \"\"}"));
        assertTrue(e.getMessage(), e.getMessage().contains("range must rise"));
        e = assertThrows(BundleException.class, () -> view("{\"name\": \"w\", \"resource\": \"r\", \"map\": \"heat\", \"description\": \"\"}"));
        assertTrue(e.getMessage(), e.getMessage().contains("map must be scalar, vector or mask, not 'heat'"));
        e = assertThrows(BundleException.class, () -> view("{\"name\": \"w\", \"resource\": \"r\", \"map\": \"mask\", \"description\": \"\"}"));
        assertTrue(e.getMessage(), e.getMessage().contains("below"));
    }

    @Test
    public void compositorPlacesThePanelsAndClampsTheSplit() {
        byte[] a = {1, 2, 3, 4, 5, 6};
        byte[] b = {10, 20, 30, 40, 50, (byte) 200};
        assertArrayEquals(new int[] {0xFF010203, 0xFF040506, 0xFF0A141E, 0xFF2832C8}, Compositor.sideBySide(a, b, 2, 1));
        assertArrayEquals(new int[] {0xFF010203, 0xFF2832C8}, Compositor.split(a, b, 2, 1, 1));
        assertArrayEquals(Compositor.split(a, b, 2, 1, 2), Compositor.split(a, b, 2, 1, 99));
        assertArrayEquals(new int[] {0xFF0A141E, 0xFF2832C8}, Compositor.split(a, b, 2, 1, -3));
        assertArrayEquals(new byte[] {1, 2, 3, 1, 2, 3, 4, 5, 6, 4, 5, 6, 1, 2, 3, 1, 2, 3, 4, 5, 6, 4, 5, 6}, Compositor.nearest(a, 2, 1, 2, 2));
        assertThrows(IllegalArgumentException.class, () -> Compositor.split(a, b, 3, 1, 1));
    }
}
