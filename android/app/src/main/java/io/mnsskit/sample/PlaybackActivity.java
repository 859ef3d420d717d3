package io.mnsskit.sample;

import android.app.Activity;
import android.content.Intent;
import android.graphics.Bitmap;
import android.graphics.Color;
import android.graphics.Typeface;
import android.graphics.drawable.BitmapDrawable;
import android.os.Bundle;
import android.os.Handler;
import android.os.HandlerThread;
import android.util.Log;
import android.view.Gravity;
import android.view.View;
import android.view.ViewGroup;
import android.widget.AdapterView;
import android.widget.ArrayAdapter;
import android.widget.Button;
import android.widget.FrameLayout;
import android.widget.ImageView;
import android.widget.LinearLayout;
import android.widget.SeekBar;
import android.widget.Spinner;
import android.widget.TextView;
import io.mnsskit.core.BundleVerifier;
import io.mnsskit.core.Compositor;
import io.mnsskit.core.DebugView;
import io.mnsskit.core.Manifest;
import io.mnsskit.core.Player;
import java.io.File;
import java.util.ArrayList;
import java.util.List;
import java.util.Locale;
import java.util.concurrent.atomic.AtomicBoolean;

/**
 * The demo screen: plays the bundle's recorded sequence in a loop through the GPU passes and the
 * NPU ({@link Player}), the model's output on the right and, on the left, the bilinear upscale of
 * the same LR frame or one of the debug views the manifest offers; side by side or cut by a
 * split slider.  An overlay shows the milliseconds of every GPU step and of the NPU call (median
 * and mean), the FPS, how the GPU was timed and which NPU path runs; the NPU path can be chosen.
 *
 * <pre>
 *   adb shell am start -n io.mnsskit.sample/.PlaybackActivity --es bundle BUNDLE --es npu nnapi
 * </pre>
 * All GL and LiteRT work runs on one background thread that owns the EGL context; the UI thread
 * only copies the composed pixels into a bitmap and asks for the next frame.
 */
public final class PlaybackActivity extends Activity {
    private static final String TAG = "mnss-kit";
    private static final String BILINEAR = "bilinear";

    private HandlerThread worker;
    private Handler gl;
    private ImageView image;
    private TextView overlay;
    private SeekBar slider;
    private Spinner views;
    private Button mode;
    private Bitmap sideBySideBitmap;
    private Bitmap splitBitmap;
    private Bitmap shown;

    // UI choices, read by the worker
    private volatile boolean sideBySide = true;
    private volatile int splitPermille = 500;
    private volatile int viewIndex; // 0: bilinear, i > 0: manifest debug view i - 1
    private volatile boolean running;
    /** A frame is posted to the worker and not yet started: one frame in flight at a time. */
    private final AtomicBoolean framePosted = new AtomicBoolean();

    // worker-thread state
    private EglComputeContext context;
    private Player player;
    private NpuRunner npuRunner;
    private Manifest manifest;
    private File bundle;
    private NpuRunner.Accelerator accelerator;
    private String failure;

    @Override
    protected void onCreate(Bundle state) {
        super.onCreate(state);
        String npu = getIntent().getStringExtra("npu");
        NpuRunner.Accelerator initial = NpuRunner.Accelerator.parse(npu == null ? "nnapi" : npu);
        setContentView(buildLayout(initial));
        worker = new HandlerThread("mnss-kit-playback");
        worker.start();
        gl = new Handler(worker.getLooper());
        String bundleName = getIntent().getStringExtra("bundle");
        gl.post(() -> open(bundleName, initial));
    }

    @Override
    protected void onResume() {
        super.onResume();
        running = true;
        requestFrame();
    }

    @Override
    protected void onPause() {
        running = false;
        super.onPause();
    }

    @Override
    protected void onDestroy() {
        running = false;
        gl.post(this::release);
        worker.quitSafely();
        super.onDestroy();
    }

    private View buildLayout(NpuRunner.Accelerator initial) {
        LinearLayout root = new LinearLayout(this);
        root.setOrientation(LinearLayout.VERTICAL);
        root.setBackgroundColor(Color.BLACK);

        LinearLayout controls = new LinearLayout(this);
        controls.setOrientation(LinearLayout.HORIZONTAL);
        Spinner delegates = new Spinner(this);
        List<String> names = new ArrayList<>();
        for (NpuRunner.Accelerator a : NpuRunner.Accelerator.values()) {
            names.add(a.label);
        }
        delegates.setAdapter(adapter(names));
        delegates.setSelection(initial.ordinal(), false);
        delegates.setOnItemSelectedListener(new Selection(position -> {
            NpuRunner.Accelerator chosen = NpuRunner.Accelerator.values()[position];
            gl.post(() -> switchNpu(chosen));
        }));
        views = new Spinner(this);
        List<String> initialViews = new ArrayList<>();
        initialViews.add(BILINEAR);
        views.setAdapter(adapter(initialViews));
        views.setOnItemSelectedListener(new Selection(position -> viewIndex = position));
        mode = new Button(this);
        mode.setText("split");
        mode.setOnClickListener(v -> setSideBySide(!sideBySide));
        Button selfTest = new Button(this);
        selfTest.setText("self-test");
        selfTest.setOnClickListener(v -> openSelfTest());
        controls.addView(delegates);
        controls.addView(views);
        controls.addView(mode);
        controls.addView(selfTest);
        root.addView(controls);

        FrameLayout stage = new FrameLayout(this);
        image = new ImageView(this);
        image.setScaleType(ImageView.ScaleType.FIT_CENTER);
        stage.addView(image, new FrameLayout.LayoutParams(ViewGroup.LayoutParams.MATCH_PARENT, ViewGroup.LayoutParams.MATCH_PARENT));
        overlay = new TextView(this);
        overlay.setTypeface(Typeface.MONOSPACE);
        overlay.setTextSize(10);
        overlay.setTextColor(Color.WHITE);
        overlay.setBackgroundColor(0x99000000);
        overlay.setPadding(8, 8, 8, 8);
        overlay.setText("loading the bundle...");
        stage.addView(overlay, new FrameLayout.LayoutParams(ViewGroup.LayoutParams.WRAP_CONTENT, ViewGroup.LayoutParams.WRAP_CONTENT,
                Gravity.TOP | Gravity.START));
        root.addView(stage, new LinearLayout.LayoutParams(ViewGroup.LayoutParams.MATCH_PARENT, 0, 1f));

        slider = new SeekBar(this);
        slider.setMax(1000);
        slider.setProgress(splitPermille);
        slider.setVisibility(View.GONE);
        slider.setOnSeekBarChangeListener(new SeekBar.OnSeekBarChangeListener() {
            @Override
            public void onProgressChanged(SeekBar bar, int progress, boolean fromUser) {
                splitPermille = progress;
            }

            @Override
            public void onStartTrackingTouch(SeekBar bar) {
            }

            @Override
            public void onStopTrackingTouch(SeekBar bar) {
            }
        });
        root.addView(slider);
        return root;
    }

    private ArrayAdapter<String> adapter(List<String> items) {
        ArrayAdapter<String> a = new ArrayAdapter<>(this, android.R.layout.simple_spinner_item, items);
        a.setDropDownViewResource(android.R.layout.simple_spinner_dropdown_item);
        return a;
    }

    /** A spinner listener that only cares about the chosen position. */
    private static final class Selection implements AdapterView.OnItemSelectedListener {
        interface OnChoice {
            void chosen(int position);
        }

        private final OnChoice choice;

        Selection(OnChoice choice) {
            this.choice = choice;
        }

        @Override
        public void onItemSelected(AdapterView<?> parent, View view, int position, long id) {
            choice.chosen(position);
        }

        @Override
        public void onNothingSelected(AdapterView<?> parent) {
        }
    }

    private void setSideBySide(boolean on) {
        sideBySide = on;
        mode.setText(on ? "split" : "side by side");
        slider.setVisibility(on ? View.GONE : View.VISIBLE);
    }

    private void openSelfTest() {
        Intent intent = new Intent(this, SelfTestActivity.class);
        File current = bundle;
        if (current != null) {
            intent.putExtra("bundle", current.getAbsolutePath());
        }
        NpuRunner.Accelerator a = accelerator;
        if (a != null) {
            intent.putExtra("npu", a.name().toLowerCase(Locale.ROOT));
        }
        startActivity(intent);
    }

    // ---- worker thread ----

    private void open(String bundleName, NpuRunner.Accelerator initial) {
        try {
            bundle = BundleStorage.find(this, bundleName);
            manifest = Manifest.load(bundle);
            List<String> problems = BundleVerifier.verify(bundle, manifest);
            if (!problems.isEmpty()) {
                throw new IllegalStateException("bundle does not match its manifest: " + problems.get(0)
                        + (problems.size() > 1 ? " (and " + (problems.size() - 1) + " more)" : ""));
            }
            context = new EglComputeContext();
            List<String> viewNames = new ArrayList<>();
            viewNames.add(BILINEAR);
            for (DebugView v : manifest.debugViews) {
                viewNames.add(v.name);
            }
            runOnUiThread(() -> views.setAdapter(adapter(viewNames)));
            switchNpu(initial);
        } catch (RuntimeException e) {
            fail(e);
        }
    }

    /** (Re)creates the player with NPU path {@code chosen}; the loop restarts at frame 0. */
    private void switchNpu(NpuRunner.Accelerator chosen) {
        if (context == null || chosen == accelerator && player != null) {
            return;
        }
        closePlayer();
        try {
            accelerator = chosen;
            failure = null;
            npuRunner = new NpuRunner(manifest, bundle, chosen);
            player = new Player(new AndroidGles31(), manifest, bundle, npuRunner, true);
            Log.i(TAG, "playing " + bundle + " with " + chosen.label + ", GPU timed by " + player.timing().label);
            requestFrame();
        } catch (RuntimeException e) {
            fail(e);
        }
    }

    /** Posts the next frame to the worker unless one is posted already. */
    private void requestFrame() {
        if (running && framePosted.compareAndSet(false, true)) {
            gl.post(this::playFrame);
        }
    }

    private void playFrame() {
        framePosted.set(false);
        if (!running || player == null || failure != null) {
            return;
        }
        try {
            Player.Frame frame = player.next();
            int index = viewIndex;
            byte[] left = index == 0 ? player.bilinear() : player.debugView(manifest.debugViews.get(index - 1));
            int[] size = player.outputSize();
            boolean both = sideBySide;
            int[] argb = both ? Compositor.sideBySide(left, frame.output, size[0], size[1])
                    : Compositor.split(left, frame.output, size[0], size[1], size[0] * splitPermille / 1000);
            String text = overlayText(frame, index);
            runOnUiThread(() -> show(argb, both ? 2 * size[0] : size[0], size[1], both, text));
        } catch (RuntimeException e) {
            fail(e);
        }
    }

    private String overlayText(Player.Frame frame, int index) {
        String left = index == 0 ? BILINEAR : manifest.debugViews.get(index - 1).name;
        return manifest.model.id + " x" + manifest.scale + "  frame " + frame.index + "/" + manifest.sequence.frames.size()
                + (frame.reset ? " (reset)" : "") + "\nleft: " + left + ", right: model\nNPU: " + accelerator.label
                + "\n" + player.stats().describe(player.timing());
    }

    private void fail(RuntimeException e) {
        Log.e(TAG, "playback failed", e);
        failure = e.getMessage();
        String path = accelerator == null ? "" : " (NPU path " + accelerator.label + "; choose another above)";
        runOnUiThread(() -> overlay.setText("ERROR: " + e.getMessage() + path));
    }

    private void closePlayer() {
        if (player != null) {
            player.close();
            player = null;
        }
        if (npuRunner != null) {
            npuRunner.close();
            npuRunner = null;
        }
    }

    private void release() {
        closePlayer();
        if (context != null) {
            context.close();
            context = null;
        }
    }

    // ---- UI thread ----

    private void show(int[] argb, int width, int height, boolean both, String text) {
        Bitmap bitmap = both ? sideBySideBitmap : splitBitmap;
        if (bitmap == null || bitmap.getWidth() != width || bitmap.getHeight() != height) {
            bitmap = Bitmap.createBitmap(width, height, Bitmap.Config.ARGB_8888);
            if (both) {
                sideBySideBitmap = bitmap;
            } else {
                splitBitmap = bitmap;
            }
        }
        bitmap.setPixels(argb, 0, width, 0, 0, width, height);
        if (bitmap != shown) {
            BitmapDrawable drawable = new BitmapDrawable(getResources(), bitmap);
            drawable.setFilterBitmap(false); // nearest: every output pixel stays visible when the view enlarges it
            image.setImageDrawable(drawable);
            shown = bitmap;
        } else {
            image.invalidate();
        }
        overlay.setText(text);
        requestFrame();
    }
}
