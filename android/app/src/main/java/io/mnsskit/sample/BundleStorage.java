package io.mnsskit.sample;

import android.content.Context;
import io.mnsskit.core.Manifest;
import java.io.File;
import java.util.Arrays;

/**
 * Where the app finds bundles and writes dumps: {@code files/bundles/NAME} and
 * {@code files/dumps/} of its external files directory
 * ({@code /sdcard/Android/data/io.mnsskit.sample/files/}), where {@code adb push} can write.
 */
final class BundleStorage {
    static final String BUNDLES = "bundles";
    static final String DUMPS = "dumps";

    private BundleStorage() {
    }

    /** The app's folder {@code folder}, created if missing. */
    static File folder(Context context, String folder) {
        File dir = new File(context.getExternalFilesDir(null), folder);
        if (!dir.isDirectory() && !dir.mkdirs()) {
            throw new IllegalStateException("cannot create " + dir);
        }
        return dir;
    }

    /** Bundle {@code name} (a directory under files/bundles/ or an absolute path), or the first one found when null. */
    static File find(Context context, String name) {
        File root = folder(context, BUNDLES);
        if (name != null) {
            File dir = name.startsWith("/") ? new File(name) : new File(root, name);
            if (!new File(dir, Manifest.FILE_NAME).isFile()) {
                throw new IllegalArgumentException(dir + " holds no manifest.json; push a bundle there first");
            }
            return dir;
        }
        File[] dirs = root.listFiles(f -> new File(f, Manifest.FILE_NAME).isFile());
        if (dirs == null || dirs.length == 0) {
            throw new IllegalArgumentException("no bundle under " + root + "; adb push one (see android/README.md)");
        }
        Arrays.sort(dirs);
        return dirs[0];
    }
}
