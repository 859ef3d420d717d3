package io.mnsskit.core;

import java.math.BigInteger;
import java.util.ArrayList;
import java.util.Iterator;
import java.util.List;
import java.util.Set;
import java.util.regex.Matcher;
import java.util.regex.Pattern;
import org.json.JSONArray;
import org.json.JSONException;
import org.json.JSONObject;
import org.json.JSONTokener;

/**
 * A value parsed by org.json (the implementation Android ships) that remembers where it was found
 * ({@code "manifest.json: npu/tensors/0/scale"}), so a missing key or a wrong type becomes a
 * one-line {@link BundleException} naming it.
 *
 * <p>A number written without fraction or exponent is integral ({@link #isIntegral()}) and read
 * exactly as a {@code long}; any other number is read as the nearest {@code double}, which holds
 * every float32 the toolkit writes exactly, so {@link #asFloat()} returns the very float32 the
 * toolkit computed.  Readers do not rely on the order of an object's members (Android's org.json
 * keeps it, the Maven artifact the desktop build tests with does not).  org.json is lenient where
 * RFC 8259 is strict (unquoted words are read as strings, a trailing comma as a null); the typed
 * accessors still refuse such a value, naming its path.
 */
public final class Json {
    private static final Pattern POSITION = Pattern.compile("(?s)(.*?) at character (\\d+)(?: of .*)?");

    private final Object value; // JSONObject, JSONArray, String, Number, Boolean, JSONObject.NULL (or null)
    private final String source; // the file name errors start with
    private final String relative; // "npu/tensors/0"; "" for the root
    private final String path; // "manifest.json: npu/tensors/0"
    private final Set<String> accessLog; // relative paths of the members read so far, or null

    private Json(Object value, String source, String relative, Set<String> accessLog) {
        this.value = value;
        this.source = source;
        this.relative = relative;
        this.path = relative.isEmpty() ? source + ":" : source + ": " + relative;
        this.accessLog = accessLog;
    }

    /** Parses {@code text}; {@code source} (a file name) starts every error message. */
    public static Json parse(String text, String source) {
        return parse(text, source, null);
    }

    /**
     * As {@link #parse(String, String)}, recording in {@code accessLog} the path of every member
     * read through {@link #get}, {@link #opt} or {@link #at}, relative to the root
     * ({@code "npu/tensors/0/scale"}).  Tests use it to show a reader covers a schema.
     */
    public static Json parse(String text, String source, Set<String> accessLog) {
        Object value;
        try {
            JSONTokener tokener = new JSONTokener(text);
            value = tokener.nextValue();
            if (tokener.nextClean() != 0) {
                throw new BundleException(source + ": not valid JSON (unexpected text after the JSON value)");
            }
        } catch (JSONException e) {
            throw new BundleException(source + ": not valid JSON (" + describe(e, text) + ")", e);
        }
        return new Json(value, source, "", accessLog);
    }

    /** org.json's message with the position of the offending character as line and column, without the echo of the whole text. */
    private static String describe(JSONException e, String text) {
        String message = String.valueOf(e.getMessage());
        Matcher m = POSITION.matcher(message);
        if (!m.matches()) {
            return message.length() > 200 ? message.substring(0, 200) + "..." : message;
        }
        // org.json reports the offset after the character it stopped at
        int at = Math.max(0, Math.min(Integer.parseInt(m.group(2)), text.length()) - 1);
        int line = 1;
        int column = 1;
        for (int i = 0; i < at; i++) {
            boolean newline = text.charAt(i) == '\n';
            line += newline ? 1 : 0;
            column = newline ? 1 : column + 1;
        }
        return m.group(1) + " at line " + line + ", column " + column;
    }

    public Object raw() {
        return value;
    }

    /** Where this value sits, e.g. {@code manifest.json: npu/tensors/0}. */
    public String path() {
        return path;
    }

    public boolean isObject() {
        return value instanceof JSONObject;
    }

    public boolean isArray() {
        return value instanceof JSONArray;
    }

    public boolean isIntegral() {
        return value instanceof Integer || value instanceof Long || value instanceof BigInteger
                || value instanceof Short || value instanceof Byte;
    }

    public boolean isNull() {
        return value == null || value == JSONObject.NULL;
    }

    public boolean has(String key) {
        return object().has(key);
    }

    /** The member {@code key}; throws naming the path if it is absent. */
    public Json get(String key) {
        JSONObject object = object();
        if (!object.has(key)) {
            throw new BundleException(path + " missing key '" + key + "'");
        }
        return visit(object.opt(key), key);
    }

    /** The member {@code key}, or {@code null} if it is absent or JSON null. */
    public Json opt(String key) {
        Object v = object().opt(key);
        return v == null || v == JSONObject.NULL ? null : visit(v, key);
    }

    public List<String> keys() {
        List<String> out = new ArrayList<>();
        for (Iterator<String> it = object().keys(); it.hasNext();) {
            out.add(it.next());
        }
        return out;
    }

    public Json at(int index) {
        JSONArray array = array();
        if (index < 0 || index >= array.length()) {
            throw new BundleException(path + " has no element " + index + " (size " + array.length() + ")");
        }
        return visit(array.opt(index), Integer.toString(index));
    }

    public int size() {
        return isObject() ? object().length() : array().length();
    }

    /** The elements of an array, each with its own path. */
    public List<Json> items() {
        List<Json> out = new ArrayList<>();
        for (int i = 0; i < array().length(); i++) {
            out.add(at(i));
        }
        return out;
    }

    public String asString() {
        return as(String.class, "a string");
    }

    public boolean asBool() {
        return as(Boolean.class, "true or false");
    }

    public long asLong() {
        if (!isIntegral()) {
            throw new BundleException(path + " expected an integer, found " + kind());
        }
        if (value instanceof BigInteger && ((BigInteger) value).bitLength() > 63) {
            throw new BundleException(path + " " + value + " does not fit a 64-bit integer");
        }
        return ((Number) value).longValue();
    }

    public int asInt() {
        long v = asLong();
        if (v != (int) v) {
            throw new BundleException(path + " " + v + " does not fit a 32-bit integer");
        }
        return (int) v;
    }

    public double asDouble() {
        return as(Number.class, "a number").doubleValue();
    }

    /** The number as float32 (the nearest one; exact for values the toolkit wrote from float32). */
    public float asFloat() {
        return (float) asDouble();
    }

    public int[] asIntArray() {
        int[] out = new int[size()];
        for (int i = 0; i < out.length; i++) {
            out[i] = at(i).asInt();
        }
        return out;
    }

    public float[] asFloatArray() {
        float[] out = new float[size()];
        for (int i = 0; i < out.length; i++) {
            out[i] = at(i).asFloat();
        }
        return out;
    }

    public List<String> asStringList() {
        List<String> out = new ArrayList<>();
        for (Json item : items()) {
            out.add(item.asString());
        }
        return out;
    }

    private JSONObject object() {
        if (!(value instanceof JSONObject)) {
            throw new BundleException(path + " expected an object, found " + kind());
        }
        return (JSONObject) value;
    }

    private JSONArray array() {
        if (!(value instanceof JSONArray)) {
            throw new BundleException(path + " expected an array, found " + kind());
        }
        return (JSONArray) value;
    }

    private <T> T as(Class<T> type, String expected) {
        if (!type.isInstance(value)) {
            throw new BundleException(path + " expected " + expected + ", found " + kind());
        }
        return type.cast(value);
    }

    private String kind() {
        if (value instanceof JSONObject) return "an object";
        if (value instanceof JSONArray) return "an array";
        if (value instanceof String) return "a string";
        if (isIntegral()) return "the integer " + value;
        if (value instanceof Number) return "the number " + value;
        if (value instanceof Boolean) return value.toString();
        return "null";
    }

    private Json visit(Object child, String key) {
        Json out = new Json(child, source, relative.isEmpty() ? key : relative + "/" + key, accessLog);
        if (accessLog != null) {
            accessLog.add(out.relative);
        }
        return out;
    }
}
