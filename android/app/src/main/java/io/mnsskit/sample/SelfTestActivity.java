package io.mnsskit.sample;

import android.app.Activity;
import android.os.Bundle;
import android.os.Handler;
import android.os.HandlerThread;
import android.util.Log;
import android.widget.ScrollView;
import android.widget.TextView;
import io.mnsskit.core.BundleVerifier;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.SelfTest;
import java.io.File;
import java.text.SimpleDateFormat;
import java.util.Date;
import java.util.List;
import java.util.Locale;

/**
 * The self-test screen: verifies a bundle pushed to app storage, runs its golden frames through
 * the GPU passes and the NPU, shows each tensor's largest difference and writes a dump for
 * {@code mnss-kit emulate --compare}.
 *
 * <pre>
 *   adb push BUNDLE /sdcard/Android/data/io.mnsskit.sample/files/bundles/BUNDLE
 *   adb shell am start -n io.mnsskit.sample/.SelfTestActivity --es bundle BUNDLE --es npu nnapi
 *   adb pull /sdcard/Android/data/io.mnsskit.sample/files/dumps/
 * </pre>
 * Without extras the first bundle found is tested with NNAPI.  All GL and LiteRT work runs on
 * one background thread that owns the EGL context.  The playback screen ({@link PlaybackActivity})
 * opens it with the bundle and NPU path it is playing.
 */
public final class SelfTestActivity extends Activity {
    private static final String TAG = "mnss-kit";
    private TextView log;
    private HandlerThread worker;

    @Override
    protected void onCreate(Bundle state) {
        super.onCreate(state);
        log = new TextView(this);
        log.setTextIsSelectable(true);
        log.setTypeface(android.graphics.Typeface.MONOSPACE);
        ScrollView scroll = new ScrollView(this);
        scroll.addView(log);
        setContentView(scroll);
        worker = new HandlerThread("mnss-kit-selftest");
        worker.start();
        String bundleName = getIntent().getStringExtra("bundle");
        String npu = getIntent().getStringExtra("npu");
        new Handler(worker.getLooper()).post(() -> run(bundleName, npu == null ? "nnapi" : npu));
    }

    @Override
    protected void onDestroy() {
        worker.quitSafely();
        super.onDestroy();
    }

    private void run(String bundleName, String npu) {
        try {
            File bundle = BundleStorage.find(this, bundleName);
            say("bundle " + bundle);
            Manifest manifest = Manifest.load(bundle);
            say("model " + manifest.model.id + " x" + manifest.scale + ", " + manifest.hrSize[0] + "x" + manifest.hrSize[1]
                    + ", " + manifest.golden.frames.size() + " golden frames (" + manifest.golden.profile + ")");
            List<String> problems = BundleVerifier.verify(bundle, manifest);
            if (!problems.isEmpty()) {
                say("bundle does not match its manifest:\n  " + String.join("\n  ", problems));
                return;
            }
            say("files and hashes verified (" + manifest.files.size() + " files)");
            NpuRunner.Accelerator accelerator = NpuRunner.Accelerator.parse(npu);
            File dump = new File(BundleStorage.folder(this, BundleStorage.DUMPS), bundle.getName() + "-" + npu + "-"
                    + new SimpleDateFormat("yyyyMMdd-HHmmss", Locale.ROOT).format(new Date()));
            try (EglComputeContext gl = new EglComputeContext();
                 GlesPipeline pipeline = new GlesPipeline(manifest, bundle, accelerator)) {
                say("GPU: " + gl.describe() + "; NPU path: " + accelerator);
                SelfTest.Report report = SelfTest.run(bundle, manifest, pipeline, dump);
                say(report.summary());
            }
            say("dump written to " + dump + "\ncompare on a desk: mnss-kit emulate --compare EMULATOR_DUMP " + dump.getName());
        } catch (RuntimeException e) {
            Log.e(TAG, "self-test failed", e);
            say("ERROR: " + e.getMessage());
        }
    }

    private void say(String line) {
        Log.i(TAG, line);
        runOnUiThread(() -> log.append(line + "\n"));
    }
}
