package io.mnsskit.core;

import java.io.File;
import java.io.IOException;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.util.Map;
import java.util.TreeMap;

/**
 * A hand-written bundle for unit tests: LR 4x2, x2, a 4-entry jitter table, three input textures, two GPU passes
 * (one skipped on reset), one NPU step, a depth ping-pong, one weight block and one golden
 * frame.  Its files are written to a directory and listed with their hashes, as export does.
 */
final class MiniBundle {
    static final String MANIFEST_TEMPLATE = """
        {
          "format": "mnss-kit-bundle",
          "format_version": %VERSION%,
          "toolkit": {"name": "mnss-kit", "version": "0.1.0"},
          "model": {"id": "mini", "family": "mnss", "config": {"scale": 2}, "checkpoint_sha256": "%ZERO%"},
          "scale": 2,
          "lr_size": [4, 2],
          "hr_size": [8, 4],
          "conventions": {"sizes": "[width, height]"},
          "jitter": {"pattern": "grid", "period": 4, "units": "lr_pixels", "sequence": [
            {"index": 0, "offset": [-0.25, -0.25], "subpixel": [0, 0]},
            {"index": 1, "offset": [0.25, 0.25], "subpixel": [1, 1]},
            {"index": 2, "offset": [0.25, -0.25], "subpixel": [1, 0]},
            {"index": 3, "offset": [-0.25, 0.25], "subpixel": [0, 1]}]},
          "stages": [{"name": "warp", "placement": "gpu", "steps": ["warp"]},
                     {"name": "recon", "placement": "npu", "steps": ["reconstruction", "unpack"], "model": "npu.tflite"}],
          "gpu": {"language": "GLSL ES 3.10",
            "passes": [
              {"name": "warp_pass", "file": "shaders/warp_pass.comp", "workgroup_size": [8, 8, 1], "grid": "hr",
               "bindings": [{"name": "prev_depth", "kind": "sampler", "unit": 0, "format": "r32f", "array": false},
                            {"name": "weights", "kind": "buffer", "unit": 0, "format": "vec4[]", "array": false},
                            {"name": "npu_input", "kind": "buffer", "unit": 1, "format": "uint[]", "array": false}],
               "uniforms": ["u_subpixel", "u_prev_jitter", "u_scale"]},
              {"name": "unpack_pass", "file": "shaders/unpack_pass.comp", "workgroup_size": [64, 1, 1], "grid": "words",
               "bindings": [{"name": "npu_output", "kind": "buffer", "unit": 0, "format": "uint[]", "array": false},
                            {"name": "depth", "kind": "image", "unit": 0, "format": "r32f", "array": false}],
               "uniforms": ["u_reset", "u_q_scale", "u_jitter"]}],
            "weights": {"file": "gpu_weights.bin", "dtype": "float32", "byte_order": "little", "alignment": 256,
              "blocks": [{"name": "w0", "offset": 256, "bytes": 16, "shape": [1, 4], "sha256": "%BLOCK%"}]}},
          "npu": {"model": "npu.tflite", "onnx": "npu_qdq.onnx", "layout": "NHWC", "inputs": ["in"], "outputs": ["out"],
            "tensors": [{"name": "in", "shape": [1, 4, 8, 3], "dtype": "int8", "scale": 0.003921568859368563, "zero_point": -128},
                        {"name": "out", "shape": [1, 4, 8, 3], "dtype": "int8", "scale": 0.00390625, "zero_point": -128}],
            "requantization_profile": "tflite-ref", "quantization": {}},
          "boundary": [%BOUNDARY_IN%, %BOUNDARY_OUT%],
          "resources": [
            {"name": "color", "kind": "texture2d", "size": [4, 2], "format": "rgba16f", "channels": 3, "role": "input"},
            {"name": "depth", "kind": "texture2d", "size": [4, 2], "format": "r32f", "role": "input"},
            {"name": "motion", "kind": "texture2d", "size": [4, 2], "format": "rg32f", "channels": 2, "role": "input"},
            {"name": "prev_depth", "kind": "texture2d", "size": [4, 2], "format": "r32f", "role": "state"},
            {"name": "npu_input", "kind": "buffer", "bytes": 96, "words": 24, "role": "boundary"},
            {"name": "npu_output", "kind": "buffer", "bytes": 96, "words": 24, "role": "boundary"},
            {"name": "display", "kind": "texture2d", "size": [8, 4], "format": "rgba8", "channels": 3, "role": "output"}],
          "schedule": {
            "steps": [
              {"kind": "gpu", "pass": "warp_pass", "label": "warp", "stage": "warp",
               "bind": {"prev_depth": "prev_depth", "weights": "weights:w0", "npu_input": "npu_input"},
               "uniforms": {"u_subpixel": {"frame": "subpixel"}, "u_prev_jitter": {"frame": "previous_offset"}, "u_scale": {"value": 2}},
               "groups": [1, 1, 1], "skip_on_reset": true},
              {"kind": "npu", "label": "reconstruction", "stage": "recon", "model": "npu.tflite",
               "inputs": {"in": "npu_input"}, "outputs": {"out": "npu_output"}},
              {"kind": "gpu", "pass": "unpack_pass", "label": "unpack", "stage": "recon",
               "bind": {"npu_output": "npu_output", "depth": "depth"},
               "uniforms": {"u_reset": {"frame": "reset"}, "u_q_scale": {"value": 0.00390625}, "u_jitter": {"frame": "offset"}},
               "groups": [1, 1, 1], "skip_on_reset": false}],
            "end_of_frame": [{"swap": ["depth", "prev_depth"]}],
            "reset": "skip warp on a reset frame", "barriers": "between steps"},
          "placement": null,
          "golden": {"profile": "tflite-ref", "source": "hand-written", "tolerances": {"npu_input_lsb": 1, "npu_output_lsb": 1, "display_codes": 1},
            "frames": [{"index": 0, "reset": true, "jitter": [-0.25, -0.25], "subpixel": [0, 0], "jitter_index": 0, "arrays": {
              "color": {"file": "golden/frame_000/color.bin", "dtype": "float16", "shape": [2, 4, 3]},
              "depth": {"file": "golden/frame_000/depth.bin", "dtype": "float32", "shape": [2, 4, 1]},
              "motion": {"file": "golden/frame_000/motion.bin", "dtype": "float32", "shape": [2, 4, 2]},
              "npu_input": {"file": "golden/frame_000/npu_input.bin", "dtype": "int8", "shape": [1, 4, 8, 3]},
              "npu_output": {"file": "golden/frame_000/npu_output.bin", "dtype": "int8", "shape": [1, 4, 8, 3]},
              "display": {"file": "golden/frame_000/display.bin", "dtype": "uint8", "shape": [4, 8, 3]}}}]},
          "files": %FILES%
        }
        """;

    static final String BOUNDARY = """
        {"role": "%ROLE%", "tensor": "%TENSOR%", "direction": "%DIR%", "layout": "NHWC", "dtype": "int8", "shape": [1, 4, 8, 3],
         "scale": %SCALE%, "zero_point": -128, "real_range": [0.0, 1.0], "bytes": 96,
         "buffer": {"resource": "%ROLE%", "packing": "NHWC bytes, 4 per uint32 word, little-endian", "words": 24},
         "texture_remap": {
           "rgba8i": {"exact": true, "real_from_code": {"multiply": %SCALE%, "add": 0.5}},
           "snorm8": {"exact": false, "real_from_texel": {"multiply": 0.5, "add": 0.5}, "texel_from_real": {"multiply": 2.0, "add": -1.0},
                      "writable_codes": [-127, 127], "unreachable_code": -128},
           "unorm8": {"exact": true, "pieces": [{"bytes": [0, 127], "real_from_texel": {"multiply": 1.0, "add": 0.5}},
                                                {"bytes": [128, 255], "real_from_texel": {"multiply": 1.0, "add": -0.5}}]}}}
        """;

    /** Relative path to contents of every file but the manifest. */
    static Map<String, byte[]> files() {
        Map<String, byte[]> files = new TreeMap<>();
        files.put("npu.tflite", bytes(64, 1));
        files.put("npu_qdq.onnx", bytes(32, 2));
        files.put("shaders/warp_pass.comp", "#version 310 es\nvoid main() {}\n".getBytes(StandardCharsets.UTF_8));
        files.put("shaders/unpack_pass.comp", "#version 310 es\nvoid main() {}\n".getBytes(StandardCharsets.UTF_8));
        files.put("gpu_weights.bin", bytes(256 + 16, 3));
        files.put("golden/frame_000/color.bin", bytes(2 * 4 * 3 * 2, 4));
        files.put("golden/frame_000/depth.bin", bytes(2 * 4 * 4, 5));
        files.put("golden/frame_000/motion.bin", bytes(2 * 4 * 2 * 4, 6));
        files.put("golden/frame_000/npu_input.bin", bytes(96, 7));
        files.put("golden/frame_000/npu_output.bin", bytes(96, 8));
        files.put("golden/frame_000/display.bin", bytes(96, 9));
        return files;
    }

    static String manifestText(int formatVersion) {
        Map<String, byte[]> files = files();
        StringBuilder table = new StringBuilder("{");
        for (Map.Entry<String, byte[]> e : files.entrySet()) {
            table.append(table.length() > 1 ? ", " : "").append('"').append(e.getKey()).append("\": {\"bytes\": ")
                    .append(e.getValue().length).append(", \"sha256\": \"").append(BundleVerifier.sha256(e.getValue())).append("\"}");
        }
        table.append('}');
        byte[] block = new byte[16];
        System.arraycopy(files.get("gpu_weights.bin"), 256, block, 0, 16);
        return MANIFEST_TEMPLATE
                .replace("%VERSION%", Integer.toString(formatVersion))
                .replace("%ZERO%", "0".repeat(64))
                .replace("%BLOCK%", BundleVerifier.sha256(block))
                .replace("%BOUNDARY_IN%", boundary("npu_input", "in", "gpu->npu", "0.003921568859368563"))
                .replace("%BOUNDARY_OUT%", boundary("npu_output", "out", "npu->gpu", "0.00390625"))
                .replace("%FILES%", table.toString());
    }

    static Manifest manifest() {
        return Manifest.parse(manifestText(1), "manifest.json", null);
    }

    /** Writes the bundle's files and manifest into {@code dir}. */
    static File write(File dir) throws IOException {
        for (Map.Entry<String, byte[]> e : files().entrySet()) {
            File f = new File(dir, e.getKey());
            f.getParentFile().mkdirs();
            Files.write(f.toPath(), e.getValue());
        }
        Files.write(new File(dir, Manifest.FILE_NAME).toPath(), manifestText(1).getBytes(StandardCharsets.UTF_8));
        return dir;
    }

    private static String boundary(String role, String tensor, String direction, String scale) {
        return BOUNDARY.replace("%ROLE%", role).replace("%TENSOR%", tensor).replace("%DIR%", direction).replace("%SCALE%", scale);
    }

    private static byte[] bytes(int n, int seed) {
        byte[] out = new byte[n];
        for (int i = 0; i < n; i++) {
            out[i] = (byte) (i * 31 + (i >> 8) * 101 + seed * 17);
        }
        return out;
    }

    private MiniBundle() {
    }
}
