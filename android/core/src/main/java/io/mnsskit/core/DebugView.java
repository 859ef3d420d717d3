package io.mnsskit.core;

import java.util.ArrayList;
import java.util.Collections;
import java.util.List;

/**
 * A debug view the manifest offers ({@code debug_views}): a texture resource and how its values
 * become colours, so the app names no stage of any family.
 *
 * <ul>
 *   <li>{@code scalar}: channel 0 from {@code range[0]} (black) to {@code range[1]} (white);
 *   <li>{@code vector}: channels 0 and 1 as a vector (+y down, as on screen): hue is the
 *       direction (0 degrees, red, pointing right; 90, yellow-green, pointing down), saturation the
 *       length from {@code range[0]} (white) to {@code range[1]} (full colour);
 *   <li>{@code mask}: {@link #MARKED} where channel 0 is below {@code below}, black elsewhere.
 * </ul>
 * On a reset frame a view with {@code on_reset} shows that value everywhere: the step that writes
 * its resource does not run then, and the texture holds an older frame's values.
 */
public final class DebugView {
    public enum Mapping { SCALAR, VECTOR, MASK }

    /** The colour of a marked pixel of a mask (orange). */
    public static final int[] MARKED = {255, 128, 0};

    public final String name;
    public final String resource;
    public final Mapping map;
    public final float low;
    public final float high;
    public final float below;
    /** The value the resource stands for on a reset frame, or null to show the texture as it is. */
    public final Float onReset;
    public final String description;

    DebugView(Json j) {
        name = j.get("name").asString();
        resource = j.get("resource").asString();
        map = read(j.get("map"));
        float[] range = map == Mapping.MASK ? new float[] {0, 0} : Manifest.pair(j.get("range")).asFloatArray();
        low = range[0];
        high = range[1];
        if (map != Mapping.MASK && !(high > low)) {
            throw new BundleException(j.get("range").path() + " must rise, got [" + low + ", " + high + "]");
        }
        below = map == Mapping.MASK ? j.get("below").asFloat() : 0;
        Json reset = j.opt("on_reset");
        onReset = reset == null ? null : reset.asFloat();
        description = j.get("description").asString();
    }

    private static Mapping read(Json j) {
        switch (j.asString()) {
            case "scalar": return Mapping.SCALAR;
            case "vector": return Mapping.VECTOR;
            case "mask": return Mapping.MASK;
            default: throw new BundleException(j.path() + " map must be scalar, vector or mask, not '" + j.asString() + "'");
        }
    }

    /** The manifest's views ({@code j} may be null: the bundle offers none); each must name a 2D texture. */
    static List<DebugView> readAll(Json j, List<GpuSection.Resource> resources) {
        List<DebugView> out = new ArrayList<>();
        if (j == null) {
            return Collections.unmodifiableList(out);
        }
        for (Json v : j.items()) {
            DebugView view = new DebugView(v);
            GpuSection.Resource r = resources.stream().filter(x -> x.name.equals(view.resource)).findFirst().orElse(null);
            if (r == null || r.kind != GpuSection.ResourceKind.TEXTURE2D) {
                throw new BundleException(v.path() + " resource '" + view.resource + "' is not a 2D texture in resources");
            }
            if (view.map == Mapping.VECTOR && r.channels == 1) {
                throw new BundleException(v.path() + " a vector view needs 2 channels; '" + view.resource + "' has 1");
            }
            out.add(view);
        }
        return Collections.unmodifiableList(out);
    }

    /**
     * {@code (h, w, 3)} codes of {@code values} ({@code w * h * channels} floats, row 0 first);
     * {@code reset}: this is a reset frame.
     */
    public byte[] render(float[] values, int channels, int w, int h, boolean reset) {
        if (values.length != w * h * channels || channels < (map == Mapping.VECTOR ? 2 : 1)) {
            throw new IllegalArgumentException(values.length + " values are not " + w + "x" + h + "x" + channels + " for view '" + name + "'");
        }
        boolean constant = reset && onReset != null;
        byte[] out = new byte[w * h * 3];
        for (int p = 0; p < w * h; p++) {
            float a = constant ? onReset : values[p * channels];
            float b = map != Mapping.VECTOR ? 0 : constant ? onReset : values[p * channels + 1];
            int[] rgb = colour(a, b);
            out[p * 3] = (byte) rgb[0];
            out[p * 3 + 1] = (byte) rgb[1];
            out[p * 3 + 2] = (byte) rgb[2];
        }
        return out;
    }

    /** The colour of one value ({@code a}; {@code (a, b)} for a vector) as 8-bit codes. */
    int[] colour(float a, float b) {
        switch (map) {
            case SCALAR: {
                int g = Bilinear.encodeUnorm8((a - low) / (high - low));
                return new int[] {g, g, g};
            }
            case MASK:
                return a < below ? MARKED.clone() : new int[] {0, 0, 0};
            case VECTOR:
            default: {
                double length = Math.sqrt((double) a * a + (double) b * b);
                double saturation = Math.max(0, Math.min(1, (length - low) / (high - low)));
                double hue = length == 0 ? 0 : (Math.toDegrees(Math.atan2(b, a)) + 360) % 360;
                return hsvToRgb(hue, saturation, 1);
            }
        }
    }

    /** HSV (hue in degrees, saturation and value in [0, 1]) to 8-bit RGB. */
    static int[] hsvToRgb(double hue, double saturation, double value) {
        double c = value * saturation;
        double hp = hue / 60;
        double x = c * (1 - Math.abs(hp % 2 - 1));
        double[] rgb;
        if (hp < 1) {
            rgb = new double[] {c, x, 0};
        } else if (hp < 2) {
            rgb = new double[] {x, c, 0};
        } else if (hp < 3) {
            rgb = new double[] {0, c, x};
        } else if (hp < 4) {
            rgb = new double[] {0, x, c};
        } else if (hp < 5) {
            rgb = new double[] {x, 0, c};
        } else {
            rgb = new double[] {c, 0, x};
        }
        double m = value - c;
        int[] out = new int[3];
        for (int k = 0; k < 3; k++) {
            out[k] = (int) Math.round((rgb[k] + m) * 255);
        }
        return out;
    }
}
