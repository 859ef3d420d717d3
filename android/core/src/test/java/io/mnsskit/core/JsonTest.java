package io.mnsskit.core;

import static org.junit.Assert.assertEquals;
import static org.junit.Assert.assertFalse;
import static org.junit.Assert.assertNull;
import static org.junit.Assert.assertThrows;
import static org.junit.Assert.assertTrue;

import java.util.Arrays;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.TreeSet;
import org.junit.Test;

public class JsonTest {
    @Test
    public void readsEveryKindOfValue() {
        Json j = Json.parse("{\"s\": \"a\\\"b\\\\c\\n\\u00e9\\ud83d\\ude00\", \"i\": -12, \"f\": 0.5, \"e\": 1e-3,"
                + " \"t\": true, \"n\": null, \"a\": [1, [2], {}], \"o\": {\"k\": []}}", "x.json");
        assertEquals("a\"b\\c\n\u00e9\ud83d\ude00", j.get("s").asString());
        assertEquals(-12, j.get("i").asInt());
        assertTrue(j.get("i").isIntegral());
        assertEquals(0.5, j.get("f").asDouble(), 0);
        assertFalse(j.get("f").isIntegral());
        assertEquals(0.001, j.get("e").asDouble(), 0);
        assertTrue(j.get("t").asBool());
        assertTrue(j.get("n").isNull());
        assertNull(j.opt("n"));
        assertNull(j.opt("absent"));
        assertEquals(3, j.get("a").size());
        assertEquals(2, j.get("a").at(1).at(0).asInt());
        assertEquals(0, j.get("o").get("k").size());
        assertEquals(new TreeSet<>(Arrays.asList("s", "i", "f", "e", "t", "n", "a", "o")), new TreeSet<>(j.keys()));
    }

    @Test
    public void integralNumbersAreExactAndDecimalsAreCorrectlyRounded() {
        Json j = Json.parse("[9007199254740993, 0.003921568859368563, 1.0, -0.0]", "x");
        assertEquals(9007199254740993L, j.at(0).asLong()); // not representable as a double
        assertEquals(1.0f / 255.0f, j.at(1).asFloat(), 0); // float32(1/255) written as its double
        assertFalse(j.at(2).isIntegral());
        assertEquals(Double.doubleToRawLongBits(-0.0), Double.doubleToRawLongBits(j.at(3).asDouble()));
    }

    @Test
    public void errorsNameTheFileThePathAndThePosition() {
        Json j = Json.parse("{\"npu\": {\"tensors\": [{\"scale\": \"big\"}]}}", "manifest.json");
        BundleException wrongType = assertThrows(BundleException.class,
                () -> j.get("npu").get("tensors").at(0).get("scale").asFloat());
        assertEquals("manifest.json: npu/tensors/0/scale expected a number, found a string", wrongType.getMessage());
        BundleException missing = assertThrows(BundleException.class, () -> j.get("npu").get("inputs"));
        assertEquals("manifest.json: npu missing key 'inputs'", missing.getMessage());
        String text = "{\n  \"a\": 1,\n  \"b\" 2}";
        BundleException syntax = assertThrows(BundleException.class, () -> Json.parse(text, "m.json"));
        assertTrue(syntax.getMessage(), syntax.getMessage().startsWith("m.json: not valid JSON ("));
        assertTrue(syntax.getMessage(), syntax.getMessage().endsWith(" at line 3, column 7)")); // where org.json stopped
        assertFalse(syntax.getMessage(), syntax.getMessage().contains("\"a\": 1")); // the text is not echoed
    }

    @Test
    public void rejectsMalformedText() {
        String[] bad = {"", "{", "[1, 2", "{\"a\" 1}", "{\"a\": 1,", "[1] 2", "{\"a\": 1} {}", "\"abc"};
        for (String text : bad) {
            assertThrows(text, BundleException.class, () -> Json.parse(text, "t"));
        }
    }

    @Test
    public void whatOrgJsonReadsLenientlyTheTypedAccessorsStillRefuse() {
        Json j = Json.parse("{\"flag\": tru, \"shape\": [1, 2,], \"n\": -}", "m.json");
        BundleException flag = assertThrows(BundleException.class, () -> j.get("flag").asBool());
        assertEquals("m.json: flag expected true or false, found a string", flag.getMessage());
        assertThrows(BundleException.class, () -> j.get("shape").asIntArray());
        BundleException n = assertThrows(BundleException.class, () -> j.get("n").asDouble());
        assertEquals("m.json: n expected a number, found a string", n.getMessage());
    }

    @Test
    public void recordsTheMembersAReaderReads() {
        TreeSet<String> log = new TreeSet<>();
        Json j = Json.parse("{\"a\": {\"b\": [10, 20], \"c\": 1}, \"d\": 2}", "x", log);
        j.get("a").get("b").at(1).asInt();
        j.opt("d");
        assertEquals(new TreeSet<>(Arrays.asList("a", "a/b", "a/b/1", "d")), log);
    }

    @Test
    public void writerOutputReadsBackToTheSameValues() {
        Map<String, Object> m = new LinkedHashMap<>();
        m.put("name", "q\"uote\\\n\u0001");
        m.put("scale", 1.0f / 255.0f);
        m.put("zero_point", -128);
        m.put("list", Arrays.asList(1, 2.5, true, null));
        m.put("shape", new int[] {1, 4, 3});
        m.put("nan", Float.NaN);
        m.put("empty", new LinkedHashMap<>());
        Json j = Json.parse(JsonWriter.write(m), "w");
        assertEquals("q\"uote\\\n\u0001", j.get("name").asString());
        assertEquals(1.0f / 255.0f, j.get("scale").asFloat(), 0);
        assertEquals(-128, j.get("zero_point").asInt());
        List<Json> list = j.get("list").items();
        assertEquals(2.5, list.get(1).asDouble(), 0);
        assertTrue(list.get(3).isNull());
        assertEquals(3, j.get("shape").asIntArray()[2]);
        assertTrue(j.get("nan").isNull());
        assertEquals(0, j.get("empty").size());
    }
}
