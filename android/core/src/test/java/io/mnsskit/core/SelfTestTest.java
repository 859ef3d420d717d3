package io.mnsskit.core;

import static org.junit.Assert.assertEquals;
import static org.junit.Assert.assertFalse;
import static org.junit.Assert.assertTrue;

import java.io.File;
import java.util.ArrayList;
import java.util.List;
import java.util.Map;
import java.util.Set;
import org.junit.Rule;
import org.junit.Test;
import org.junit.rules.TemporaryFolder;

public class SelfTestTest {
    @Rule
    public TemporaryFolder tmp = new TemporaryFolder();

    @Test
    public void comparatorCountsLsbsOnStoredIntegers() {
        Tensor a = Tensor.int8("npu_input", new int[] {1, 2, 2, 1}, new byte[] {-128, 0, 5, 127}, 0.5f, 0);
        Tensor b = Tensor.int8("npu_input", new int[] {1, 2, 2, 1}, new byte[] {-128, 2, 4, 127}, 0.5f, 0);
        TensorComparator.Result r = TensorComparator.compare(a, b, 3, 1);
        assertEquals(2.0, r.maxDiff, 0);
        assertTrue(r.inLsb);
        assertEquals(2, r.mismatches);
        assertEquals(1, r.firstMismatch);
        assertFalse(r.passed());
        assertTrue(TensorComparator.compare(a, a, 0, 0).passed());
        assertTrue(r.summary(), r.summary().contains("FAIL"));
    }

    @Test
    public void comparatorUsesRealValuesWhenQuantizationDiffers() {
        Tensor a = Tensor.int8("t", new int[] {2}, new byte[] {2, 4}, 0.5f, 0);
        Tensor b = Tensor.int8("t", new int[] {2}, new byte[] {1, 2}, 1.0f, 0);
        TensorComparator.Result r = TensorComparator.compare(a, b, 0, 0);
        assertFalse(r.inLsb);
        assertEquals(0.0, r.maxDiff, 0);
    }

    @Test
    public void halfFloatsDecodeExactly() {
        assertEquals(1.0f, Tensor.halfToFloat(0x3C00), 0);
        assertEquals(-2.0f, Tensor.halfToFloat(0xC000), 0);
        assertEquals(65504.0f, Tensor.halfToFloat(0x7BFF), 0);
        assertEquals(0x1p-24f, Tensor.halfToFloat(0x0001), 0);
        assertEquals(Float.POSITIVE_INFINITY, Tensor.halfToFloat(0x7C00), 0);
        assertTrue(Float.isNaN(Tensor.halfToFloat(0x7E00)));
    }

    /** A device that returns the golden values, optionally with one NPU output value off by {@code error} LSB. */
    private static final class EchoPipeline implements SelfTest.Pipeline {
        final File bundle;
        final Manifest manifest;
        final int error;
        int frames;

        EchoPipeline(File bundle, Manifest manifest, int error) {
            this.bundle = bundle;
            this.manifest = manifest;
            this.error = error;
        }

        private Golden.Frame frame() {
            return manifest.golden.frames.get(frames);
        }

        @Override
        public Map<String, byte[]> beforeNpu(FrameScheduler.FramePlan plan, Map<String, Tensor> inputs, List<String> npuInputs) {
            assertEquals(frame().reset || frames == 0, plan.reset);
            assertEquals(frame().subpixel[0], plan.jitter.subpixelX);
            assertEquals(List.of("color", "depth", "motion"), new ArrayList<>(inputs.keySet()));
            assertEquals(Tensor.DType.FLOAT16, inputs.get("color").dtype);
            assertEquals(List.of("npu_input"), npuInputs);
            return Map.of("npu_input", frame().read(bundle, "npu_input").data);
        }

        @Override
        public Map<String, byte[]> npu(Map<String, byte[]> inputs) {
            assertEquals(Set.of("in"), inputs.keySet()); // the model's tensor names
            byte[] out = frame().read(bundle, "npu_output").data;
            out[5] += error;
            return Map.of("out", out);
        }

        @Override
        public byte[] afterNpu(FrameScheduler.FramePlan plan, Map<String, byte[]> npuOutputs, String output) {
            assertEquals(Set.of("npu_output"), npuOutputs.keySet());
            assertEquals("display", output);
            byte[] display = frame().read(bundle, output).data;
            frames++;
            return display;
        }
    }

    @Test
    public void goldenEchoPassesAndWritesADump() throws Exception {
        File bundle = MiniBundle.write(tmp.newFolder("bundle"));
        Manifest m = Manifest.load(bundle);
        File dump = tmp.newFolder("dump");
        SelfTest.Report report = SelfTest.run(bundle, m, new EchoPipeline(bundle, m, 0), dump);
        assertTrue(report.summary(), report.passed());
        assertEquals(3, report.results.size());
        Json index = Json.parse(new String(java.nio.file.Files.readAllBytes(new File(dump, "index.json").toPath()), "UTF-8"), "index.json");
        assertEquals("mnss-kit-dump", index.get("format").asString());
        List<Json> tensors = index.get("tensors").items();
        assertEquals("in", tensors.get(0).get("name").asString()); // the NPU model's tensor names, as the emulator dumps them
        assertEquals("npu", tensors.get(0).get("stage").asString());
        assertEquals(-128, tensors.get(0).get("zero_point").asInt());
        assertEquals("uint8", tensors.get(2).get("dtype").asString());
        String file = index.get("frames").at(0).get("files").get("out").asString();
        assertEquals("frame_00000/out.bin", file);
        assertEquals(96, new File(dump, file).length());
    }

    @Test
    public void anNpuOutputTwoLsbOffFails() throws Exception {
        File bundle = MiniBundle.write(tmp.newFolder("bundle"));
        Manifest m = Manifest.load(bundle);
        SelfTest.Report report = SelfTest.run(bundle, m, new EchoPipeline(bundle, m, 2), null);
        assertFalse(report.passed());
        TensorComparator.Result npu = report.results.get(1);
        assertEquals("npu_output", npu.name);
        assertEquals(2.0, npu.maxDiff, 0);
        assertEquals(5, npu.firstMismatch);
        assertTrue(report.results.get(0).passed());
    }
}
