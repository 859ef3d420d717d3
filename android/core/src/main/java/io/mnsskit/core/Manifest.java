package io.mnsskit.core;

import java.io.File;
import java.io.IOException;
import java.math.BigDecimal;
import java.math.RoundingMode;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.util.ArrayList;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.Set;

/**
 * {@code manifest.json} of an mnss-kit bundle, read into plain objects (format version 1,
 * {@code mnss_kit/schemas/manifest.schema.json}; {@code docs/bundle.md} explains the fields).
 *
 * <p>Reading checks the format and refuses a newer format version before anything else, then
 * reads every field the schema requires; a missing field or a wrong type is a
 * {@link BundleException} naming its JSON path.  Sizes are {@code [width, height]}; NPU shapes
 * are NHWC.  Free-form sections ({@code model.config}, {@code conventions}, {@code placement},
 * {@code npu.quantization}, {@code golden.tolerances}) stay {@link Json}.
 */
public final class Manifest {
    public static final String FILE_NAME = "manifest.json";
    public static final String FORMAT = "mnss-kit-bundle";
    /** The newest format version this reader understands. */
    public static final int FORMAT_VERSION = 1;

    public static final double MIN_SCALE = 1.25;
    public static final double MAX_SCALE = 4.0;

    /** An integer scale: each HR pixel belongs to one LR pixel's {@code s x s} tile. */
    public static boolean isInteger(double scale) {
        return scale == Math.rint(scale);
    }

    /**
     * {@code round_half_up(hr / scale)} with the scale as the decimal it was written as (1.7, not
     * the nearest double): {@code mnss_kit.ops.scale.lr_size_for}, 1280 at 1.7 is 753, 720 is 424.
     */
    public static int lrSizeFor(int hr, double scale) {
        return new BigDecimal(hr).divide(new BigDecimal(Double.toString(scale)), 0, RoundingMode.HALF_UP).intValueExact();
    }

    public final int formatVersion;
    public final String toolkitName;
    public final String toolkitVersion;
    public final Model model;
    /** 2, 3, 4, or a quality mode such as 1.5 (then {@code lrSize = round_half_up(hrSize / scale)} per axis). */
    public final double scale;
    public final int[] lrSize;
    public final int[] hrSize;
    public final Json conventions;
    public final Jitter jitter;
    public final List<Stage> stages;
    public final GpuSection gpu;
    public final NpuSection npu;
    public final List<NpuSection.Boundary> boundary;
    public final List<GpuSection.Resource> resources;
    public final Schedule schedule;
    /** The split stage's placement report, or null. */
    public final Json placement;
    public final Golden golden;
    /** The recorded input sequence for playback, or null if the bundle carries none. */
    public final Sequence sequence;
    /** The resources the bundle offers as debug views (empty when it offers none). */
    public final List<DebugView> debugViews;
    /** Every file of the bundle but the manifest: relative POSIX path to size and SHA-256. */
    public final Map<String, FileEntry> files;

    /** The model the bundle runs: {@code id} names it in logs and in the app. */
    public static final class Model {
        public final String id;
        public final String family;
        public final Json config;
        public final String checkpointSha256;

        Model(Json j) {
            id = j.get("id").asString();
            family = j.get("family").asString();
            config = j.get("config");
            checkpointSha256 = j.get("checkpoint_sha256").asString();
        }
    }

    /** One entry of the jitter table: offset in LR pixels from the pixel centre, sub-pixel (dx, dy). */
    public static final class JitterEntry {
        public final int index;
        public final float offsetX;
        public final float offsetY;
        public final int subpixelX;
        public final int subpixelY;

        public JitterEntry(int index, float offsetX, float offsetY, int subpixelX, int subpixelY) {
            this.index = index;
            this.offsetX = offsetX;
            this.offsetY = offsetY;
            this.subpixelX = subpixelX;
            this.subpixelY = subpixelY;
        }

        static JitterEntry read(Json j, double scale) {
            float[] offset = pair(j.get("offset")).asFloatArray();
            int[] sub = pair(j.get("subpixel")).asIntArray();
            int tile = isInteger(scale) ? (int) scale : 1;  // a fractional scale has no tile: sub-pixel (0, 0)
            for (int v : sub) {
                if (v < 0 || v >= tile) {
                    throw new BundleException(j.path() + " sub-pixel " + v + " outside the " + tile + "x" + tile + " tile");
                }
            }
            return new JitterEntry(j.get("index").asInt(), offset[0], offset[1], sub[0], sub[1]);
        }
    }

    /** The camera jitter the engine must apply: frame t uses {@code sequence[t mod period]}. */
    public static final class Jitter {
        public final String pattern;
        public final int period;
        public final String units;
        public final List<JitterEntry> sequence;

        Jitter(Json j, double scale) {
            pattern = j.get("pattern").asString();
            period = j.get("period").asInt();
            units = j.get("units").asString();
            List<JitterEntry> entries = new ArrayList<>();
            for (Json e : j.get("sequence").items()) {
                entries.add(JitterEntry.read(e, scale));
            }
            if (entries.isEmpty() || entries.size() != period) {
                throw new BundleException(j.path() + " has " + entries.size() + " sequence entries for period " + period);
            }
            for (int t = 0; t < entries.size(); t++) {
                if (entries.get(t).index != t) {
                    throw new BundleException(j.path() + " sequence entry " + t + " has index " + entries.get(t).index);
                }
            }
            sequence = Collections.unmodifiableList(entries);
        }

        public JitterEntry forFrame(long frame) {
            return sequence.get((int) Math.floorMod(frame, (long) period));
        }
    }

    public enum Placement {
        GPU, NPU;

        static Placement read(Json j) {
            switch (j.asString()) {
                case "gpu": return GPU;
                case "npu": return NPU;
                default: throw new BundleException(j.path() + " placement must be 'gpu' or 'npu', not '" + j.asString() + "'");
            }
        }
    }

    /** A model stage, where it runs, and the labels of the schedule steps that run it. */
    public static final class Stage {
        public final String name;
        public final Placement placement;
        public final List<String> steps;

        Stage(Json j) {
            name = j.get("name").asString();
            placement = Placement.read(j.get("placement"));
            steps = j.get("steps").asStringList();
        }
    }

    public static final class FileEntry {
        public final long bytes;
        public final String sha256;

        FileEntry(Json j) {
            bytes = j.get("bytes").asLong();
            sha256 = j.get("sha256").asString();
        }
    }

    private Manifest(Json root) {
        formatVersion = checkFormat(root);
        Json toolkit = root.get("toolkit");
        toolkitName = toolkit.get("name").asString();
        toolkitVersion = toolkit.get("version").asString();
        model = new Model(root.get("model"));
        scale = root.get("scale").asDouble();
        if (!(scale >= MIN_SCALE && scale <= MAX_SCALE)) {
            throw new BundleException(root.get("scale").path() + " must be in [" + MIN_SCALE + ", " + MAX_SCALE + "], got " + scale);
        }
        lrSize = size(root.get("lr_size"));
        hrSize = size(root.get("hr_size"));
        if (isInteger(scale)) {
            int s = (int) scale;
            if (hrSize[0] != lrSize[0] * s || hrSize[1] != lrSize[1] * s) {
                throw new BundleException(root.path() + " hr_size is not lr_size times scale " + s);
            }
        } else {
            for (int axis = 0; axis < 2; axis++) {
                if (lrSize[axis] != lrSizeFor(hrSize[axis], scale)) {
                    throw new BundleException(root.path() + " lr_size is not round_half_up(hr_size / " + scale + ") per axis");
                }
            }
        }
        conventions = root.get("conventions");
        jitter = new Jitter(root.get("jitter"), scale);
        List<Stage> stageList = new ArrayList<>();
        for (Json s : root.get("stages").items()) {
            stageList.add(new Stage(s));
        }
        stages = Collections.unmodifiableList(stageList);
        gpu = new GpuSection(root.get("gpu"));
        npu = new NpuSection(root.get("npu"));
        boundary = NpuSection.readBoundary(root.get("boundary"));
        resources = GpuSection.readResources(root.get("resources"));
        schedule = new Schedule(root.get("schedule"));
        placement = root.get("placement").isNull() ? null : root.get("placement");
        golden = new Golden(root.get("golden"), resources, boundary);
        Json sequenceJson = root.opt("sequence");
        sequence = sequenceJson == null ? null : new Sequence(sequenceJson, resources);
        debugViews = DebugView.readAll(root.opt("debug_views"), resources);
        Map<String, FileEntry> table = new LinkedHashMap<>();
        Json filesJson = root.get("files");
        for (String name : filesJson.keys()) {
            table.put(name, new FileEntry(filesJson.get(name)));
        }
        files = Collections.unmodifiableMap(table);
    }

    /** Reads {@code bundle/manifest.json}. */
    public static Manifest load(File bundle) {
        return parse(readText(new File(bundle, FILE_NAME)), bundle.getName() + "/" + FILE_NAME, null);
    }

    /**
     * Parses manifest text.  {@code accessLog} (may be null) receives the JSON path of every
     * member read, for tests that check the reader against the schema.
     */
    public static Manifest parse(String text, String source, Set<String> accessLog) {
        return new Manifest(Json.parse(text, source, accessLog));
    }

    static String readText(File file) {
        if (!file.isFile()) {
            throw new BundleException(file + ": missing (not an mnss-kit bundle?)");
        }
        try {
            return new String(Files.readAllBytes(file.toPath()), StandardCharsets.UTF_8);
        } catch (IOException e) {
            throw new BundleException(file + ": cannot read (" + e.getMessage() + ")", e);
        }
    }

    /** The format gate: a foreign file or a newer format version is refused with an upgrade hint. */
    private static int checkFormat(Json root) {
        if (!root.isObject() || !root.has("format") || !FORMAT.equals(root.get("format").raw())) {
            throw new BundleException(root.path() + " not an mnss-kit bundle manifest (format is not '" + FORMAT + "')");
        }
        Json v = root.get("format_version");
        if (!v.isIntegral() || v.asLong() < 1) {
            throw new BundleException(v.path() + " must be a positive integer");
        }
        if (v.asLong() > FORMAT_VERSION) {
            throw new BundleException(root.path() + " bundle format version " + v.asLong() + " is newer than this app reads (up to "
                    + FORMAT_VERSION + "); update the app or export with a matching mnss-kit");
        }
        return v.asInt();
    }

    public NpuSection.Boundary boundary(String role) {
        for (NpuSection.Boundary b : boundary) {
            if (b.role.equals(role)) {
                return b;
            }
        }
        throw new BundleException("manifest.json: no boundary tensor with role '" + role + "'");
    }

    public GpuSection.Resource resource(String name) {
        for (GpuSection.Resource r : resources) {
            if (r.name.equals(name)) {
                return r;
            }
        }
        throw new BundleException("manifest.json: no resource named '" + name + "'");
    }

    static int[] size(Json j) {
        int[] wh = pair(j).asIntArray();
        if (wh[0] < 1 || wh[1] < 1) {
            throw new BundleException(j.path() + " sizes must be positive, got [" + wh[0] + ", " + wh[1] + "]");
        }
        return wh;
    }

    static Json pair(Json j) {
        if (j.size() != 2) {
            throw new BundleException(j.path() + " must have 2 elements, has " + j.size());
        }
        return j;
    }

    static int[] shape(Json j) {
        int[] s = j.asIntArray();
        for (int d : s) {
            if (d < 1) {
                throw new BundleException(j.path() + " dimensions must be positive");
            }
        }
        return s;
    }
}
