package io.mnsskit.core;

import java.util.ArrayList;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.Set;

/**
 * A small JSON reader (RFC 8259) for the bundle manifest, golden and dump indexes; org.json is
 * part of Android, not of plain Java, and the core must run on both.
 *
 * <p>A parsed value remembers where it was found ({@code "manifest.json: npu/tensors/0/scale"}),
 * so a missing key or a wrong type becomes a one-line {@link BundleException} naming it.
 * Objects keep their key order.  A number written without fraction or exponent is integral
 * ({@link #isIntegral()}) and read exactly as a {@code long}; any other number is read as the
 * nearest {@code double}, which holds every float32 the toolkit writes exactly, so
 * {@link #asFloat()} returns the very float32 the toolkit computed.
 */
public final class Json {
    /** The JSON {@code null}, so that a present-but-null value differs from an absent key. */
    public static final Object NULL = new Object() {
        @Override
        public String toString() {
            return "null";
        }
    };

    private final Object value; // Map<String,Object>, List<Object>, String, Long, Double, Boolean or NULL
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
        Parser parser = new Parser(text, source);
        parser.skipSpace();
        Object value = parser.value();
        parser.skipSpace();
        if (parser.pos != text.length()) {
            throw parser.error("unexpected text after the JSON value");
        }
        return new Json(value, source, "", accessLog);
    }

    public Object raw() {
        return value;
    }

    /** Where this value sits, e.g. {@code manifest.json: npu/tensors/0}. */
    public String path() {
        return path;
    }

    public boolean isObject() {
        return value instanceof Map;
    }

    public boolean isArray() {
        return value instanceof List;
    }

    public boolean isIntegral() {
        return value instanceof Long;
    }

    public boolean isNull() {
        return value == NULL;
    }

    public boolean has(String key) {
        return object().containsKey(key);
    }

    /** The member {@code key}; throws naming the path if it is absent. */
    public Json get(String key) {
        Map<String, Object> map = object();
        if (!map.containsKey(key)) {
            throw new BundleException(path + " missing key '" + key + "'");
        }
        return visit(map.get(key), key);
    }

    /** The member {@code key}, or {@code null} if it is absent or JSON null. */
    public Json opt(String key) {
        Map<String, Object> map = object();
        Object v = map.get(key);
        return v == null || v == NULL ? null : visit(v, key);
    }

    public List<String> keys() {
        return new ArrayList<>(object().keySet());
    }

    public Json at(int index) {
        List<Object> list = array();
        if (index < 0 || index >= list.size()) {
            throw new BundleException(path + " has no element " + index + " (size " + list.size() + ")");
        }
        return visit(list.get(index), Integer.toString(index));
    }

    public int size() {
        return isObject() ? object().size() : array().size();
    }

    /** The elements of an array, each with its own path. */
    public List<Json> items() {
        List<Json> out = new ArrayList<>();
        for (int i = 0; i < array().size(); i++) {
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
        return as(Long.class, "an integer");
    }

    public int asInt() {
        long v = asLong();
        if (v != (int) v) {
            throw new BundleException(path + " " + v + " does not fit a 32-bit integer");
        }
        return (int) v;
    }

    public double asDouble() {
        if (value instanceof Long) {
            return (Long) value;
        }
        return as(Double.class, "a number");
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

    @SuppressWarnings("unchecked")
    private Map<String, Object> object() {
        if (!(value instanceof Map)) {
            throw new BundleException(path + " expected an object, found " + kind());
        }
        return (Map<String, Object>) value;
    }

    @SuppressWarnings("unchecked")
    private List<Object> array() {
        if (!(value instanceof List)) {
            throw new BundleException(path + " expected an array, found " + kind());
        }
        return (List<Object>) value;
    }

    private <T> T as(Class<T> type, String expected) {
        if (!type.isInstance(value)) {
            throw new BundleException(path + " expected " + expected + ", found " + kind());
        }
        return type.cast(value);
    }

    private String kind() {
        if (value instanceof Map) return "an object";
        if (value instanceof List) return "an array";
        if (value instanceof String) return "a string";
        if (value instanceof Long) return "the integer " + value;
        if (value instanceof Double) return "the number " + value;
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


    /** Recursive descent over the text; positions in errors are line:column. */
    private static final class Parser {
        private static final int MAX_DEPTH = 256;
        private final String text;
        private final String source;
        private int pos;
        private int depth;

        Parser(String text, String source) {
            this.text = text;
            this.source = source;
        }

        Object value() {
            if (pos >= text.length()) {
                throw error("unexpected end of text");
            }
            char c = text.charAt(pos);
            switch (c) {
                case '{': return object();
                case '[': return array();
                case '"': return string();
                case 't': return literal("true", Boolean.TRUE);
                case 'f': return literal("false", Boolean.FALSE);
                case 'n': return literal("null", NULL);
                default:
                    if (c == '-' || (c >= '0' && c <= '9')) {
                        return number();
                    }
                    throw error("unexpected character '" + c + "'");
            }
        }

        private Map<String, Object> object() {
            enter();
            Map<String, Object> map = new LinkedHashMap<>();
            pos++; // '{'
            skipSpace();
            if (peek() == '}') {
                pos++;
                depth--;
                return map;
            }
            while (true) {
                skipSpace();
                if (peek() != '"') {
                    throw error("expected a string key");
                }
                String key = string();
                skipSpace();
                expect(':');
                skipSpace();
                if (map.put(key, value()) != null) {
                    throw error("duplicate key '" + key + "'");
                }
                skipSpace();
                if (peek() == ',') {
                    pos++;
                } else {
                    expect('}');
                    depth--;
                    return map;
                }
            }
        }

        private List<Object> array() {
            enter();
            List<Object> list = new ArrayList<>();
            pos++; // '['
            skipSpace();
            if (peek() == ']') {
                pos++;
                depth--;
                return Collections.unmodifiableList(list);
            }
            while (true) {
                skipSpace();
                list.add(value());
                skipSpace();
                if (peek() == ',') {
                    pos++;
                } else {
                    expect(']');
                    depth--;
                    return Collections.unmodifiableList(list);
                }
            }
        }

        private String string() {
            pos++; // opening quote
            StringBuilder out = new StringBuilder();
            while (true) {
                if (pos >= text.length()) {
                    throw error("unterminated string");
                }
                char c = text.charAt(pos++);
                if (c == '"') {
                    return out.toString();
                }
                if (c < 0x20) {
                    throw error("control character in a string");
                }
                if (c != '\\') {
                    out.append(c);
                    continue;
                }
                char e = pos < text.length() ? text.charAt(pos++) : '\0';
                switch (e) {
                    case '"': out.append('"'); break;
                    case '\\': out.append('\\'); break;
                    case '/': out.append('/'); break;
                    case 'b': out.append('\b'); break;
                    case 'f': out.append('\f'); break;
                    case 'n': out.append('\n'); break;
                    case 'r': out.append('\r'); break;
                    case 't': out.append('\t'); break;
                    case 'u': out.append(hex4()); break; // surrogate pairs arrive as two \\u escapes
                    default: throw error("bad escape '\\" + e + "'");
                }
            }
        }

        private char hex4() {
            if (pos + 4 > text.length()) {
                throw error("truncated \\u escape");
            }
            try {
                char c = (char) Integer.parseInt(text.substring(pos, pos + 4), 16);
                pos += 4;
                return c;
            } catch (NumberFormatException e) {
                throw error("bad \\u escape");
            }
        }

        private Object number() {
            int start = pos;
            boolean integral = true;
            if (peek() == '-') pos++;
            if (peek() == '0') {
                pos++;
            } else if (!digits()) {
                throw error("bad number");
            }
            if (peek() == '.') {
                pos++;
                integral = false;
                if (!digits()) throw error("bad number: digits expected after '.'");
            }
            if (peek() == 'e' || peek() == 'E') {
                pos++;
                integral = false;
                if (peek() == '+' || peek() == '-') pos++;
                if (!digits()) throw error("bad number: digits expected in the exponent");
            }
            String literal = text.substring(start, pos);
            if (integral) {
                try {
                    return Long.parseLong(literal);
                } catch (NumberFormatException tooLarge) {
                    return Double.parseDouble(literal);
                }
            }
            return Double.parseDouble(literal); // correctly rounded (Java spec)
        }

        private boolean digits() {
            int start = pos;
            while (pos < text.length() && text.charAt(pos) >= '0' && text.charAt(pos) <= '9') pos++;
            return pos > start;
        }

        private Object literal(String word, Object result) {
            if (!text.startsWith(word, pos)) {
                throw error("unexpected word");
            }
            pos += word.length();
            return result;
        }

        void skipSpace() {
            while (pos < text.length()) {
                char c = text.charAt(pos);
                if (c != ' ' && c != '\t' && c != '\n' && c != '\r') return;
                pos++;
            }
        }

        private char peek() {
            return pos < text.length() ? text.charAt(pos) : '\0';
        }

        private void expect(char c) {
            if (peek() != c) {
                throw error("expected '" + c + "'");
            }
            pos++;
        }

        private void enter() {
            if (++depth > MAX_DEPTH) {
                throw error("nesting deeper than " + MAX_DEPTH);
            }
        }

        BundleException error(String what) {
            int line = 1;
            int column = 1;
            for (int i = 0; i < Math.min(pos, text.length()); i++) {
                if (text.charAt(i) == '\n') {
                    line++;
                    column = 1;
                } else {
                    column++;
                }
            }
            return new BundleException(source + ": not valid JSON (" + what + " at line " + line + ", column " + column + ")");
        }
    }
}
