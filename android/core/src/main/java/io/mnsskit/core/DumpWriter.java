package io.mnsskit.core;

import java.io.File;
import java.io.FileOutputStream;
import java.io.IOException;
import java.nio.charset.StandardCharsets;
import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * Writes a tensor dump that {@code mnss-kit emulate --compare} reads ({@code mnss_kit/emulate/dump.py},
 * {@code docs/emulator.md}): a directory with {@code index.json} and one raw little-endian
 * {@code .bin} file per tensor and frame, C order.
 *
 * <pre>
 *   index.json   {"format": "mnss-kit-dump", "version": 1, ...info,
 *                 "tensors": [{"name", "dtype", "shape", "scale"?, "zero_point"?, "stage"?}, ...],
 *                 "frames":  [{"index": 0, "files": {"npu_input": "frame_00000/npu_input.bin", ...}}, ...]}
 * </pre>
 *
 * Tensors are listed in the order first written (execution order).  Quantized tensors are stored
 * as their integers with {@code real = scale * (q - zero_point)}.  The index is rewritten after
 * every frame through a temporary file and a rename, so a reader never sees a partial index.
 */
public final class DumpWriter {
    public static final String FORMAT = "mnss-kit-dump";
    public static final int VERSION = 1;
    public static final String INDEX = "index.json";

    private final File dir;
    private final Map<String, Object> info;
    private final Map<String, Map<String, Object>> tensors = new LinkedHashMap<>();
    private final List<Map<String, Object>> frames = new ArrayList<>();

    /** {@code info}: extra top-level keys (device, bundle model id, ...), may be empty. */
    public DumpWriter(File dir, Map<String, Object> info) {
        if (!dir.isDirectory() && !dir.mkdirs()) {
            throw new BundleException(dir + ": cannot create the dump directory");
        }
        this.dir = dir;
        this.info = new LinkedHashMap<>(info);
    }

    /** Writes one frame's tensors (in execution order); {@code stages} maps tensor names to stage names (may be empty). */
    public File writeFrame(int index, List<Tensor> frameTensors, Map<String, String> stages) {
        String folder = String.format("frame_%05d", index);
        Map<String, Object> files = new LinkedHashMap<>();
        for (Tensor t : frameTensors) {
            String relative = folder + "/" + fileName(t.name, files.size()) + ".bin";
            writeAtomically(new File(dir, relative), t.data);
            files.put(t.name, relative);
            tensors.putIfAbsent(t.name, entry(t, stages.get(t.name)));
        }
        Map<String, Object> frame = new LinkedHashMap<>();
        frame.put("index", index);
        frame.put("files", files);
        frames.add(frame);
        File indexFile = new File(dir, INDEX);
        writeAtomically(indexFile, JsonWriter.write(index()).getBytes(StandardCharsets.UTF_8));
        return indexFile;
    }

    private Map<String, Object> index() {
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("format", FORMAT);
        out.put("version", VERSION);
        out.putAll(info);
        out.put("tensors", new ArrayList<>(tensors.values()));
        out.put("frames", frames);
        return out;
    }

    static Map<String, Object> entry(Tensor t, String stage) {
        Map<String, Object> e = new LinkedHashMap<>();
        e.put("name", t.name);
        e.put("dtype", t.dtype.id);
        List<Object> shape = new ArrayList<>();
        for (int d : t.shape) {
            shape.add(d);
        }
        e.put("shape", shape);
        if (t.scale != null) {
            e.put("scale", t.scale);
            e.put("zero_point", t.zeroPoint);
        }
        if (stage != null) {
            e.put("stage", stage);
        }
        return e;
    }

    /** A file-system-safe name for a tensor name ({@code recon/conv:0} -> {@code recon_conv_0}). */
    static String fileName(String tensorName, int position) {
        String safe = tensorName.replaceAll("[^A-Za-z0-9_.-]", "_");
        if (safe.isEmpty() || safe.startsWith(".") || !safe.equals(tensorName)) {
            safe = String.format("%03d_%s", position, safe); // keep distinct names distinct
        }
        return safe;
    }

    static void writeAtomically(File target, byte[] data) {
        File parent = target.getParentFile();
        if (parent != null && !parent.isDirectory() && !parent.mkdirs()) {
            throw new BundleException(parent + ": cannot create directory");
        }
        File tmp = new File(parent, "." + target.getName() + ".tmp");
        try (FileOutputStream out = new FileOutputStream(tmp)) {
            out.write(data);
            out.getFD().sync();
        } catch (IOException e) {
            tmp.delete();
            throw new BundleException(target + ": cannot write (" + e.getMessage() + ")", e);
        }
        if (!tmp.renameTo(target)) {
            tmp.delete();
            throw new BundleException(target + ": cannot rename the temporary file into place");
        }
    }
}
