package io.mnsskit.core;

import java.io.File;
import java.io.FileInputStream;
import java.io.IOException;
import java.io.InputStream;
import java.security.MessageDigest;
import java.security.NoSuchAlgorithmException;
import java.util.ArrayList;
import java.util.List;
import java.util.TreeSet;

/**
 * Checks a bundle copy against its manifest before anything is loaded: every listed file is
 * present with its size and SHA-256, no file lies in the bundle unlisted, and every GPU weight
 * block inside the weight file has its own recorded hash.  A truncated {@code adb push} or an
 * edited shader shows up here, one line per problem.
 */
public final class BundleVerifier {
    private static final int CHUNK = 1 << 16;
    private static final char[] HEX = "0123456789abcdef".toCharArray();

    private BundleVerifier() {
    }

    /** Problems found (empty: the copy is the exported bundle). */
    public static List<String> verify(File bundle, Manifest manifest) {
        List<String> problems = new ArrayList<>();
        for (String name : manifest.files.keySet()) {
            Manifest.FileEntry entry = manifest.files.get(name);
            File file = new File(bundle, name);
            if (!file.isFile()) {
                problems.add(name + ": missing (listed in manifest.json)");
            } else if (file.length() != entry.bytes) {
                problems.add(name + ": " + file.length() + " bytes, manifest.json says " + entry.bytes);
            } else if (!sha256(file).equals(entry.sha256)) {
                problems.add(name + ": SHA-256 differs from manifest.json (file changed or corrupt)");
            }
        }
        for (String name : listFiles(bundle)) {
            if (!manifest.files.containsKey(name)) {
                problems.add(name + ": not listed in manifest.json");
            }
        }
        if (problems.isEmpty()) {
            problems.addAll(verifyWeightBlocks(bundle, manifest));
        }
        return problems;
    }

    /** Each weight block's bytes hash to the block's recorded SHA-256. */
    static List<String> verifyWeightBlocks(File bundle, Manifest manifest) {
        List<String> problems = new ArrayList<>();
        GpuSection.Weights w = manifest.gpu.weights;
        File file = new File(bundle, w.file);
        byte[] data = readAll(file);
        for (GpuSection.WeightBlock block : w.blocks.values()) {
            long end = block.offset + block.bytes;
            if (end > data.length) {
                problems.add(w.file + ": weight block '" + block.name + "' runs past the end of the file");
                continue;
            }
            MessageDigest digest = newDigest();
            digest.update(data, (int) block.offset, (int) block.bytes);
            if (!hex(digest.digest()).equals(block.sha256)) {
                problems.add(w.file + ": weight block '" + block.name + "' SHA-256 differs from manifest.json");
            }
        }
        return problems;
    }

    /** Hex SHA-256 of a file, read in chunks. */
    public static String sha256(File file) {
        MessageDigest digest = newDigest();
        byte[] buffer = new byte[CHUNK];
        try (InputStream in = new FileInputStream(file)) {
            int n;
            while ((n = in.read(buffer)) > 0) {
                digest.update(buffer, 0, n);
            }
        } catch (IOException e) {
            throw new BundleException(file + ": cannot read (" + e.getMessage() + ")", e);
        }
        return hex(digest.digest());
    }

    public static String sha256(byte[] data) {
        return hex(newDigest().digest(data));
    }

    /** Every regular file under {@code root} but the manifest, as sorted relative POSIX paths. */
    static TreeSet<String> listFiles(File root) {
        TreeSet<String> out = new TreeSet<>();
        collect(root, "", out);
        out.remove(Manifest.FILE_NAME);
        return out;
    }

    private static void collect(File dir, String prefix, TreeSet<String> out) {
        File[] children = dir.listFiles();
        if (children == null) {
            return;
        }
        for (File child : children) {
            String name = prefix + child.getName();
            if (child.isDirectory()) {
                collect(child, name + "/", out);
            } else if (child.isFile()) {
                out.add(name);
            }
        }
    }

    private static byte[] readAll(File file) {
        try {
            return java.nio.file.Files.readAllBytes(file.toPath());
        } catch (IOException e) {
            throw new BundleException(file + ": cannot read (" + e.getMessage() + ")", e);
        }
    }

    private static MessageDigest newDigest() {
        try {
            return MessageDigest.getInstance("SHA-256");
        } catch (NoSuchAlgorithmException e) {
            throw new IllegalStateException("SHA-256 is required on every Java platform", e);
        }
    }

    static String hex(byte[] bytes) {
        char[] out = new char[bytes.length * 2];
        for (int i = 0; i < bytes.length; i++) {
            out[2 * i] = HEX[(bytes[i] >> 4) & 0xF];
            out[2 * i + 1] = HEX[bytes[i] & 0xF];
        }
        return new String(out);
    }
}
