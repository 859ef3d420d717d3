package io.mnsskit.core;

import static org.junit.Assert.assertArrayEquals;
import static org.junit.Assert.assertEquals;
import static org.junit.Assert.assertNull;
import static org.junit.Assert.assertThrows;
import static org.junit.Assert.assertTrue;

import java.util.List;
import org.junit.Test;

public class ManifestTest {
    @Test
    public void readsTheSections() {
        Manifest m = MiniBundle.manifest();
        assertEquals("mini", m.model.id);
        assertEquals(2.0, m.scale, 0.0);
        assertArrayEquals(new int[] {8, 4}, m.hrSize);
        assertEquals(4, m.jitter.period);
        assertEquals(1, m.jitter.forFrame(5).subpixelX);
        assertEquals(3, m.jitter.forFrame(-1).index);
        assertEquals(Manifest.Placement.NPU, m.stages.get(1).placement);
        assertEquals(GpuSection.BindingKind.BUFFER, m.gpu.passes.get("warp_pass").bindings.get("weights").kind);
        assertEquals(256, m.gpu.weights.blocks.get("w0").offset);
        assertEquals(1.0f / 255.0f, m.boundary("npu_input").scale, 0);
        assertEquals(-128, m.npu.tensors.get("out").zeroPoint);
        assertEquals(2, m.schedule.endOfFrameSwaps.get(0).length);
        assertNull(m.placement);
        assertEquals(1, m.golden.toleranceFor("display"));
        assertEquals(11, m.files.size());
        Schedule.UniformSource scale = m.schedule.steps.get(0).uniforms.get("u_scale");
        assertTrue(scale.integral);
        assertEquals(Schedule.FrameValue.PREVIOUS_OFFSET, m.schedule.steps.get(0).uniforms.get("u_prev_jitter").frame);
    }

    @Test
    public void goldenArraysFollowTheResources() {
        Manifest m = MiniBundle.manifest();
        assertEquals(List.of("color", "depth", "motion"), m.golden.inputs);
        assertEquals(List.of("npu_input", "npu_output"), m.golden.boundaries);
        assertEquals("display", m.golden.output);
        assertEquals(1, m.golden.toleranceFor("npu_output"));
        String wrongDtype = MiniBundle.manifestText(1).replace("color.bin\", \"dtype\": \"float16\"", "color.bin\", \"dtype\": \"float32\"");
        BundleException e = assertThrows(BundleException.class, () -> Manifest.parse(wrongDtype, "manifest.json", null));
        assertTrue(e.getMessage(), e.getMessage().contains("golden/frames/0/arrays/color is float32 [2, 4, 3]; resource 'color' needs float16"));
        String extraInput = MiniBundle.manifestText(1).replace("\"resources\": [", "\"resources\": [{\"name\": \"albedo\", "
                + "\"kind\": \"texture2d\", \"size\": [8, 4], \"format\": \"rgba16f\", \"role\": \"input\"}, ");
        e = assertThrows(BundleException.class, () -> Manifest.parse(extraInput, "manifest.json", null));
        assertTrue(e.getMessage(), e.getMessage().contains("golden/frames/0/arrays missing golden array 'albedo' (input resource)"));
    }

    @Test
    public void refusesANewerFormatWithAnUpgradeHint() {
        BundleException e = assertThrows(BundleException.class,
                () -> Manifest.parse(MiniBundle.manifestText(2), "manifest.json", null));
        assertTrue(e.getMessage(), e.getMessage().contains("format version 2 is newer than this app reads (up to 1)"));
    }

    @Test
    public void refusesAForeignFile() {
        BundleException e = assertThrows(BundleException.class,
                () -> Manifest.parse("{\"format\": \"something-else\"}", "manifest.json", null));
        assertTrue(e.getMessage(), e.getMessage().contains("not an mnss-kit bundle manifest"));
    }

    @Test
    public void namesTheMissingField() {
        String text = MiniBundle.manifestText(1).replace("\"zero_point\": -128, \"real_range\"", "\"real_range\"");
        BundleException e = assertThrows(BundleException.class, () -> Manifest.parse(text, "manifest.json", null));
        assertEquals("manifest.json: boundary/0 missing key 'zero_point'", e.getMessage());
    }

    @Test
    public void rejectsInconsistentSizes() {
        String text = MiniBundle.manifestText(1).replace("\"hr_size\": [8, 4]", "\"hr_size\": [8, 6]");
        assertThrows(BundleException.class, () -> Manifest.parse(text, "manifest.json", null));
    }

    @Test
    public void remapsReadUnorm8Pieces() {
        NpuSection.TextureRemap r = MiniBundle.manifest().boundary("npu_input").textureRemap;
        assertEquals(0.5 + 100 / 255.0, r.realFromUnorm8(100 / 255.0), 1e-12);
        assertEquals(-0.5 + 200 / 255.0, r.realFromUnorm8(200 / 255.0), 1e-12);
    }
}
