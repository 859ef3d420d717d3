package io.mnsskit.core;

import java.util.ArrayList;
import java.util.HashSet;
import java.util.List;
import java.util.Map;
import java.util.Set;

/**
 * Consistency of a manifest's schedule with what it names: passes, their declared bindings and
 * uniforms, resources, weight blocks, NPU tensors, swaps between like resources, and workgroup
 * counts that cover each pass's grid.  One line per problem, naming the step.
 */
public final class ScheduleCheck {
    private ScheduleCheck() {
    }

    public static List<String> problems(Manifest m) {
        List<String> out = new ArrayList<>();
        Set<String> resources = new HashSet<>();
        for (GpuSection.Resource r : m.resources) {
            resources.add(r.name);
        }
        int npuSteps = 0;
        for (int i = 0; i < m.schedule.steps.size(); i++) {
            Schedule.Step step = m.schedule.steps.get(i);
            String where = "manifest.json: schedule step " + i + " (" + step.label + ")";
            if (step.kind == Schedule.Kind.NPU) {
                npuSteps++;
                npuStep(m, step, resources, where, out);
            } else {
                gpuStep(m, step, resources, where, out);
            }
        }
        if (npuSteps != 1) {
            out.add("manifest.json: schedule has " + npuSteps + " NPU steps; this app runs exactly one");
        }
        for (String[] swap : m.schedule.endOfFrameSwaps) {
            swap(m, swap, resources, out);
        }
        return out;
    }

    private static void npuStep(Manifest m, Schedule.Step step, Set<String> resources, String where, List<String> out) {
        if (!step.model.equals(m.npu.model)) {
            out.add(where + ": model '" + step.model + "' is not npu.model '" + m.npu.model + "'");
        }
        check(step.inputs, m.npu.inputs, resources, where, out);
        check(step.outputs, m.npu.outputs, resources, where, out);
    }

    private static void check(Map<String, String> tensors, List<String> declared, Set<String> resources, String where, List<String> out) {
        for (Map.Entry<String, String> e : tensors.entrySet()) {
            if (!declared.contains(e.getKey())) {
                out.add(where + ": '" + e.getKey() + "' is not an input or output of the NPU model");
            }
            if (!resources.contains(e.getValue())) {
                out.add(where + ": resource '" + e.getValue() + "' is not in resources");
            }
        }
    }

    private static void gpuStep(Manifest m, Schedule.Step step, Set<String> resources, String where, List<String> out) {
        GpuSection.Pass pass = m.gpu.passes.get(step.pass);
        if (pass == null) {
            out.add(where + ": pass '" + step.pass + "' is not in gpu.passes");
            return;
        }
        for (Map.Entry<String, String> e : step.bind.entrySet()) {
            if (!pass.bindings.containsKey(e.getKey())) {
                out.add(where + ": binds '" + e.getKey() + "', which " + pass.name + " does not declare");
            }
            String target = e.getValue();
            boolean known = target.startsWith(Schedule.WEIGHTS_PREFIX)
                    ? m.gpu.weights.blocks.containsKey(target.substring(Schedule.WEIGHTS_PREFIX.length()))
                    : resources.contains(target);
            if (!known) {
                out.add(where + ": '" + target + "' is not defined");
            }
        }
        for (String binding : pass.bindings.keySet()) {
            if (!step.bind.containsKey(binding)) {
                out.add(where + ": nothing bound to '" + binding + "'");
            }
        }
        for (String uniform : pass.uniforms) {
            if (!step.uniforms.containsKey(uniform)) {
                out.add(where + ": no value for uniform '" + uniform + "'");
            }
        }
        for (String uniform : step.uniforms.keySet()) {
            if (!pass.uniforms.contains(uniform)) {
                out.add(where + ": uniform '" + uniform + "' is not declared by " + pass.name);
            }
        }
        coverage(m, step, pass, where, out);
    }

    /** The dispatch must reach every element of the pass's grid. */
    private static void coverage(Manifest m, Schedule.Step step, GpuSection.Pass pass, String where, List<String> out) {
        int[] g = step.groups;
        int[] l = pass.workgroupSize;
        for (int v : g) {
            if (v < 1) {
                out.add(where + ": workgroup counts must be positive");
                return;
            }
        }
        long[] need;
        switch (pass.grid) {
            case "hr": need = new long[] {m.hrSize[0], m.hrSize[1]}; break;
            case "lr": case "lr_layers": need = new long[] {m.lrSize[0], m.lrSize[1]}; break;
            case "words": need = new long[] {m.boundary("npu_input").words, 1}; break;
            default:
                out.add(where + ": unknown grid '" + pass.grid + "'");
                return;
        }
        boolean covered = pass.grid.equals("words")
                ? (long) g[0] * g[1] * l[0] >= need[0]
                : (long) g[0] * l[0] >= need[0] && (long) g[1] * l[1] >= need[1];
        if (!covered) {
            out.add(where + ": groups " + g[0] + "x" + g[1] + "x" + g[2] + " do not cover the " + pass.grid + " grid");
        }
    }

    private static void swap(Manifest m, String[] swap, Set<String> resources, List<String> out) {
        if (!resources.contains(swap[0]) || !resources.contains(swap[1])) {
            out.add("manifest.json: end_of_frame swaps unknown resources " + swap[0] + ", " + swap[1]);
            return;
        }
        GpuSection.Resource a = m.resource(swap[0]);
        GpuSection.Resource b = m.resource(swap[1]);
        boolean alike = a.kind == b.kind && a.layers == b.layers && a.bytes == b.bytes
                && java.util.Objects.equals(a.format, b.format) && java.util.Arrays.equals(a.size, b.size);
        if (!alike) {
            out.add("manifest.json: end_of_frame swaps " + a.name + " and " + b.name + ", which differ in kind, size or format");
        }
    }
}
