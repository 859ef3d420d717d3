package io.mnsskit.core;

/**
 * A bundle (or dump, or golden file) that cannot be used as it is: missing, corrupt, a newer
 * format, a field of the wrong type.  The message is one line naming the file and, where known,
 * the JSON path, so the app can show it as it is.
 */
public class BundleException extends RuntimeException {
    private static final long serialVersionUID = 1L;

    public BundleException(String message) {
        super(message);
    }

    public BundleException(String message, Throwable cause) {
        super(message, cause);
    }
}
