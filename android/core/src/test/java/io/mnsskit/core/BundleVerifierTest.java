package io.mnsskit.core;

import static org.junit.Assert.assertEquals;
import static org.junit.Assert.assertTrue;

import java.io.File;
import java.io.RandomAccessFile;
import java.nio.file.Files;
import java.util.Arrays;
import java.util.Collections;
import java.util.List;
import org.junit.Rule;
import org.junit.Test;
import org.junit.rules.TemporaryFolder;

public class BundleVerifierTest {
    @Rule
    public TemporaryFolder tmp = new TemporaryFolder();

    @Test
    public void sha256OfKnownInputs() {
        assertEquals("e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855", BundleVerifier.sha256(new byte[0]));
        assertEquals("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad",
                BundleVerifier.sha256("abc".getBytes(java.nio.charset.StandardCharsets.US_ASCII)));
    }

    @Test
    public void anIntactCopyHasNoProblems() throws Exception {
        File dir = MiniBundle.write(tmp.newFolder("bundle"));
        assertEquals(Collections.emptyList(), BundleVerifier.verify(dir, Manifest.load(dir)));
    }

    @Test
    public void reportsChangedTruncatedMissingAndUnlistedFiles() throws Exception {
        File dir = MiniBundle.write(tmp.newFolder("bundle"));
        try (RandomAccessFile f = new RandomAccessFile(new File(dir, "shaders/warp_pass.comp"), "rw")) {
            f.seek(3);
            f.write('X');
        }
        try (RandomAccessFile f = new RandomAccessFile(new File(dir, "npu.tflite"), "rw")) {
            f.setLength(10);
        }
        assertTrue(new File(dir, "golden/frame_000/display.bin").delete());
        Files.write(new File(dir, "shaders/extra.comp").toPath(), new byte[] {1});
        List<String> problems = BundleVerifier.verify(dir, Manifest.load(dir));
        assertEquals(Arrays.asList(
                "golden/frame_000/display.bin: missing (listed in manifest.json)",
                "npu.tflite: 10 bytes, manifest.json says 64",
                "shaders/warp_pass.comp: SHA-256 differs from manifest.json (file changed or corrupt)",
                "shaders/extra.comp: not listed in manifest.json"), problems);
    }

    @Test
    public void checksWeightBlocksInsideTheWeightFile() throws Exception {
        File dir = MiniBundle.write(tmp.newFolder("bundle"));
        Manifest m = Manifest.load(dir);
        assertEquals(Collections.emptyList(), BundleVerifier.verifyWeightBlocks(dir, m));
        String text = MiniBundle.manifestText(1).replace("\"offset\": 256, \"bytes\": 16", "\"offset\": 0, \"bytes\": 16");
        List<String> problems = BundleVerifier.verifyWeightBlocks(dir, Manifest.parse(text, "manifest.json", null));
        assertEquals(Collections.singletonList("gpu_weights.bin: weight block 'w0' SHA-256 differs from manifest.json"), problems);
    }
}
