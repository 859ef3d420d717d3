package io.mnsskit.core;

import static org.junit.Assert.assertArrayEquals;
import static org.junit.Assert.assertEquals;
import static org.junit.Assert.assertFalse;
import static org.junit.Assert.assertSame;
import static org.junit.Assert.assertThrows;
import static org.junit.Assert.assertTrue;

import java.util.Arrays;
import java.util.List;
import org.junit.Test;

public class FrameSchedulerTest {
    @Test
    public void firstFrameAndCutsSkipTheHistorySteps() {
        FrameScheduler s = new FrameScheduler(MiniBundle.manifest());
        FrameScheduler.FramePlan first = s.next(false);
        assertTrue(first.reset);
        assertEquals(Arrays.asList("reconstruction", "unpack"), first.labels());
        assertEquals(1, first.steps.get(1).uniforms.get("u_reset").ints()[0]);
        FrameScheduler.FramePlan second = s.next(false);
        assertFalse(second.reset);
        assertEquals(Arrays.asList("warp", "reconstruction", "unpack"), second.labels());
        assertEquals(0, second.steps.get(2).uniforms.get("u_reset").ints()[0]);
        FrameScheduler.FramePlan cut = s.next(true);
        assertTrue(cut.reset);
        assertEquals(2, cut.labels().size());
        assertSame(first.jitter, first.previousJitter); // no previous frame: its own entry
        assertSame(second.jitter, cut.previousJitter); // a cut still has one (mnss_kit/gpu/interpret.py)
    }

    @Test
    public void jitterCyclesThroughTheTableAndPassesThePreviousEntry() {
        FrameScheduler s = new FrameScheduler(MiniBundle.manifest());
        int[][] expected = {{0, 0}, {1, 1}, {1, 0}, {0, 1}, {0, 0}, {1, 1}};
        Manifest.JitterEntry previous = null;
        for (int t = 0; t < expected.length; t++) {
            FrameScheduler.FramePlan plan = s.next(false);
            assertEquals(t % 4, plan.jitter.index);
            if (t > 0) {
                FrameScheduler.PlannedStep warp = plan.steps.get(0);
                assertArrayEquals(expected[t], warp.uniforms.get("u_subpixel").ints());
                assertArrayEquals(new float[] {previous.offsetX, previous.offsetY}, warp.uniforms.get("u_prev_jitter").floats(), 0);
                assertFalse(warp.uniforms.get("u_prev_jitter").integral);
            }
            float[] offset = plan.steps.get(plan.steps.size() - 1).uniforms.get("u_jitter").floats();
            assertArrayEquals(new float[] {plan.jitter.offsetX, plan.jitter.offsetY}, offset, 0);
            previous = plan.jitter;
        }
    }

    @Test
    public void depthAndPreviousDepthPingPong() {
        FrameScheduler s = new FrameScheduler(MiniBundle.manifest());
        List<String> seen = new java.util.ArrayList<>();
        for (int t = 0; t < 4; t++) {
            FrameScheduler.FramePlan plan = s.next(false);
            seen.add(plan.physical("depth"));
            String written = plan.steps.get(plan.steps.size() - 1).bind.get("depth");
            assertEquals(plan.physical("depth"), written);
            if (t > 0) {
                // last frame's depth allocation is read as prev_depth now
                assertEquals(seen.get(t - 1), plan.steps.get(0).bind.get("prev_depth"));
            }
        }
        assertEquals(Arrays.asList("depth", "prev_depth", "depth", "prev_depth"), seen);
    }

    @Test
    public void constantsWeightBlocksAndNpuTensorsPassThrough() {
        FrameScheduler s = new FrameScheduler(MiniBundle.manifest());
        FrameScheduler.FramePlan first = s.next(false);
        FrameScheduler.PlannedStep npu = first.steps.get(0);
        assertEquals(null, npu.pass);
        assertEquals("npu_input", npu.bind.get("in"));
        assertEquals("npu_output", npu.bind.get("out"));
        FrameScheduler.PlannedStep unpack = first.steps.get(1);
        assertEquals("unpack_pass", unpack.pass.name);
        assertEquals(0.00390625f, unpack.uniforms.get("u_q_scale").floats()[0], 0);
        FrameScheduler.PlannedStep warp = s.next(false).steps.get(0);
        assertEquals("weights:w0", warp.bind.get("weights"));
        assertArrayEquals(new int[] {2}, warp.uniforms.get("u_scale").ints());
    }

    @Test
    public void aBrokenScheduleIsRefusedBeforeAnyGlWork() {
        String[][] breakages = {
            {"\"weights\": \"weights:w0\"", "\"weights\": \"weights:nope\""},
            {"\"u_scale\": {\"value\": 2}", "\"u_other\": {\"value\": 2}"},
            {"\"depth\": \"depth\"}", "\"depth\": \"dept\"}"},
            {"\"inputs\": {\"in\": \"npu_input\"}", "\"inputs\": {\"x\": \"npu_input\"}"},
            {"\"groups\": [1, 1, 1], \"skip_on_reset\": true", "\"groups\": [0, 1, 1], \"skip_on_reset\": true"},
            {"\"workgroup_size\": [8, 8, 1]", "\"workgroup_size\": [4, 2, 1]"},
        };
        for (String[] b : breakages) {
            String text = MiniBundle.manifestText(1).replace(b[0], b[1]);
            assertTrue("replacement applies: " + b[0], !text.equals(MiniBundle.manifestText(1)));
            Manifest m = Manifest.parse(text, "manifest.json", null);
            assertThrows(b[1], BundleException.class, () -> new FrameScheduler(m));
        }
        assertTrue(ScheduleCheck.problems(MiniBundle.manifest()).isEmpty());
    }
}
