package io.mnsskit.core;

import java.util.Arrays;

/**
 * The self-test's verdict on one tensor: the device's result against the golden one.
 *
 * <p>Integer tensors with the same scale and zero point compare their stored integers: the
 * largest difference is in LSBs (quantization steps; codes for the uint8 display), as the
 * desktop compare tool ({@code mnss_kit.emulate.compare}) counts them.  Float tensors compare
 * values and report the largest absolute difference.  A tensor passes when its largest
 * difference is within the tolerance the bundle states (golden.tolerances).
 */
public final class TensorComparator {
    private TensorComparator() {
    }

    public static final class Result {
        public final String name;
        public final int frame;
        /** Largest difference: LSBs for integer tensors, absolute value for float ones. */
        public final double maxDiff;
        public final boolean inLsb;
        public final long mismatches;
        public final long count;
        /** Flat index of the first differing element, or -1. */
        public final long firstMismatch;
        public final double tolerance;

        Result(String name, int frame, double maxDiff, boolean inLsb, long mismatches, long count, long firstMismatch, double tolerance) {
            this.name = name;
            this.frame = frame;
            this.maxDiff = maxDiff;
            this.inLsb = inLsb;
            this.mismatches = mismatches;
            this.count = count;
            this.firstMismatch = firstMismatch;
            this.tolerance = tolerance;
        }

        public boolean passed() {
            return maxDiff <= tolerance;
        }

        public double mismatchFraction() {
            return count == 0 ? 0 : (double) mismatches / count;
        }

        /** One line for the app's screen and log. */
        public String summary() {
            String diff = inLsb ? (long) maxDiff + " LSB" : String.format("%.3g", maxDiff);
            String tol = inLsb ? (long) tolerance + " LSB" : String.format("%.3g", tolerance);
            return String.format("frame %d %-10s %s  max diff %s (allowed %s), %.4f%% differ%s", frame, name,
                    passed() ? "PASS" : "FAIL", diff, tol, 100 * mismatchFraction(),
                    firstMismatch >= 0 ? ", first at element " + firstMismatch : "");
        }
    }

    /** Compares {@code actual} to {@code expected}; shapes must match. */
    public static Result compare(Tensor actual, Tensor expected, int frame, double tolerance) {
        if (!Arrays.equals(actual.shape, expected.shape)) {
            throw new BundleException("tensor '" + expected.name + "' frame " + frame + ": shape " + Arrays.toString(actual.shape)
                    + " on the device, " + Arrays.toString(expected.shape) + " in the golden file");
        }
        boolean integers = actual.dtype.integer && expected.dtype.integer && sameParams(actual, expected);
        int n = expected.count();
        double max = 0;
        long mismatches = 0;
        long first = -1;
        for (int i = 0; i < n; i++) {
            double d = integers
                    ? Math.abs(actual.intAt(i) - expected.intAt(i))
                    : Math.abs(actual.realAt(i) - expected.realAt(i));
            if (d != 0 || Double.isNaN(d)) {
                mismatches++;
                if (first < 0) {
                    first = i;
                }
                max = Double.isNaN(d) ? Double.POSITIVE_INFINITY : Math.max(max, d);
            }
        }
        return new Result(expected.name, frame, max, integers, mismatches, n, first, tolerance);
    }

    private static boolean sameParams(Tensor a, Tensor b) {
        if (a.scale == null || b.scale == null) {
            return a.scale == null && b.scale == null;
        }
        return a.scale.floatValue() == b.scale.floatValue() && a.zeroPoint == b.zeroPoint;
    }
}
