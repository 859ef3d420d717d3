package io.mnsskit.core;

import java.io.File;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.util.ArrayList;
import java.util.HashSet;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.Set;
import java.util.TreeSet;

/**
 * Runs the core on a real exported bundle for {@code tests/android/test_bundle_contract.py},
 * which compares what it prints with the toolkit's own reading of the same bundle.
 *
 * <pre>
 *   verify   BUNDLE                      problems, one per line (nothing: intact)
 *   read     BUNDLE ACCESS_LOG           JSON summary of the parsed manifest; every JSON path read -> ACCESS_LOG
 *   schedule BUNDLE FRAMES CUT,CUT,...   JSON: per frame reset, jitter, step labels, bindings and uniform values
 *   sequence BUNDLE                     JSON: the recorded sequence's frames (reset, jitter index) and, per input
 *                                        resource, each frame's SHA-256 and its first and last values
 *   selftest BUNDLE DUMP ERROR           golden echo through SelfTest, NPU output value 7 off by ERROR LSB;
 *                                        the input resources fed ("inputs: a,b"), then the report
 * </pre>
 */
public final class ContractTool {
    private ContractTool() {
    }

    public static void main(String[] args) throws Exception {
        File bundle = new File(args[1]);
        switch (args[0]) {
            case "verify":
                for (String problem : BundleVerifier.verify(bundle, Manifest.load(bundle))) {
                    System.out.println(problem);
                }
                break;
            case "read":
                read(bundle, new File(args[2]));
                break;
            case "schedule":
                schedule(Manifest.load(bundle), Integer.parseInt(args[2]), args.length > 3 ? args[3] : "");
                break;
            case "sequence":
                sequence(bundle, Manifest.load(bundle));
                break;
            case "selftest":
                selftest(bundle, new File(args[2]), Integer.parseInt(args[3]));
                break;
            default:
                throw new IllegalArgumentException("unknown command " + args[0]);
        }
    }

    private static void read(File bundle, File accessLog) throws Exception {
        Set<String> log = new TreeSet<>();
        String text = Manifest.readText(new File(bundle, Manifest.FILE_NAME));
        Manifest m = Manifest.parse(text, "manifest.json", log);
        Files.write(accessLog.toPath(), String.join("\n", log).getBytes(StandardCharsets.UTF_8));
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("model", m.model.id);
        out.put("scale", m.scale);
        out.put("lr_size", list(m.lrSize));
        out.put("hr_size", list(m.hrSize));
        List<Object> jitter = new ArrayList<>();
        for (Manifest.JitterEntry e : m.jitter.sequence) {
            jitter.add(List.of(e.offsetX, e.offsetY, e.subpixelX, e.subpixelY));
        }
        out.put("jitter", jitter);
        List<Object> stages = new ArrayList<>();
        for (Manifest.Stage s : m.stages) {
            stages.add(List.of(s.name, s.placement.name().toLowerCase()));
        }
        out.put("stages", stages);
        out.put("passes", new ArrayList<>(m.gpu.passes.keySet()));
        Map<String, Object> boundary = new LinkedHashMap<>();
        for (NpuSection.Boundary b : m.boundary) {
            boundary.put(b.role, List.of(b.tensor, b.scale, b.zeroPoint, list(b.shape), b.words));
        }
        out.put("boundary", boundary);
        out.put("golden_frames", m.golden.frames.size());
        out.put("golden_inputs", m.golden.inputs);
        out.put("files", m.files.size());
        out.put("schedule_problems", ScheduleCheck.problems(m));
        System.out.print(JsonWriter.write(out));
    }

    private static void schedule(Manifest m, int frames, String cutList) {
        Set<Integer> cuts = new HashSet<>();
        for (String c : cutList.split(",")) {
            if (!c.isEmpty()) {
                cuts.add(Integer.parseInt(c));
            }
        }
        FrameScheduler scheduler = new FrameScheduler(m);
        List<Object> out = new ArrayList<>();
        for (int t = 0; t < frames; t++) {
            FrameScheduler.FramePlan plan = scheduler.next(cuts.contains(t));
            Map<String, Object> frame = new LinkedHashMap<>();
            frame.put("reset", plan.reset);
            frame.put("jitter_index", plan.jitter.index);
            List<Object> steps = new ArrayList<>();
            for (FrameScheduler.PlannedStep s : plan.steps) {
                Map<String, Object> step = new LinkedHashMap<>();
                step.put("label", s.step.label);
                step.put("bind", new LinkedHashMap<>(s.bind));
                Map<String, Object> uniforms = new LinkedHashMap<>();
                s.uniforms.forEach((name, u) -> {
                    List<Object> values = new ArrayList<>();
                    for (double v : u.values) {
                        values.add(v);
                    }
                    uniforms.put(name, values);
                });
                step.put("uniforms", uniforms);
                steps.add(step);
            }
            frame.put("steps", steps);
            out.add(frame);
        }
        System.out.print(JsonWriter.write(out));
    }

    private static void sequence(File bundle, Manifest m) throws Exception {
        Sequence.Loaded loaded = m.sequence.load(bundle);
        List<Object> frames = new ArrayList<>();
        Map<String, List<Object>> arrays = new LinkedHashMap<>();
        for (int t = 0; t < m.sequence.frames.size(); t++) {
            Sequence.Frame f = m.sequence.frames.get(t);
            frames.add(List.of(f.reset, f.jitter.index));
            for (Map.Entry<String, Tensor> e : loaded.frame(t).entrySet()) {
                Tensor x = e.getValue();
                StringBuilder hex = new StringBuilder();
                for (byte b : java.security.MessageDigest.getInstance("SHA-256").digest(x.data)) {
                    hex.append(String.format("%02x", b));
                }
                arrays.computeIfAbsent(e.getKey(), k -> new ArrayList<>()).add(List.of(hex.toString(), x.realAt(0), x.realAt(x.count() - 1)));
            }
        }
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("frames", frames);
        out.put("arrays", arrays);
        System.out.print(JsonWriter.write(out));
    }

    /** A device that answers with the golden values, one NPU output value off by {@code error}. */
    private static void selftest(File bundle, File dump, int error) {
        Manifest m = Manifest.load(bundle);
        int[] frame = {0};
        Set<String> inputsSeen = new TreeSet<>();
        SelfTest.Pipeline echo = new SelfTest.Pipeline() {
            Golden.Frame current() {
                return m.golden.frames.get(frame[0]);
            }

            @Override
            public Map<String, byte[]> beforeNpu(FrameScheduler.FramePlan plan, Map<String, Tensor> inputs, List<String> npuInputs) {
                inputsSeen.addAll(inputs.keySet());
                Map<String, byte[]> out = new LinkedHashMap<>();
                for (String r : npuInputs) {
                    out.put(r, current().read(bundle, r).data);
                }
                return out;
            }

            @Override
            public Map<String, byte[]> npu(Map<String, byte[]> inputs) {
                Map<String, byte[]> out = new LinkedHashMap<>();
                m.schedule.npuStep().outputs.forEach((tensor, resource) -> out.put(tensor, current().read(bundle, resource).data));
                byte[] first = out.values().iterator().next();
                first[7] = (byte) Math.max(-128, Math.min(127, first[7] + (first[7] > 0 ? -error : error)));
                return out;
            }

            @Override
            public byte[] afterNpu(FrameScheduler.FramePlan plan, Map<String, byte[]> npuOutputs, String output) {
                byte[] display = current().read(bundle, output).data;
                frame[0]++;
                return display;
            }
        };
        String summary = SelfTest.run(bundle, m, echo, dump).summary();
        System.out.println("inputs: " + String.join(",", inputsSeen));
        System.out.println(summary);
    }

    private static List<Object> list(int[] values) {
        List<Object> out = new ArrayList<>();
        for (int v : values) {
            out.add(v);
        }
        return out;
    }
}
