// The material picker: a <select> of the real-material presets (brdfkit.materials), grouped
// by fit, beside the "add a BRDF" box. Choosing one adds it as an entry through that box, so the
// preset is an ordinary spec (material(name=..., fit=...)) that every control then edits.
export function materialPicker(root, presets) {
  const box = root.querySelector(".bx-add-spec");
  if (!box || !presets || !presets.length) return null;
  const picker = document.createElement("select");
  picker.className = "bx-add-material";
  picker.title = "add a real material (a published fit to a MERL measurement)";
  picker.append(new Option(`add a material (${presets.length})…`, ""));
  const groups = new Map();
  for (const [fit, name, spec] of presets) {
    if (!groups.has(fit)) {
      const group = document.createElement("optgroup");
      group.label = fit;
      groups.set(fit, group);
      picker.append(group);
    }
    groups.get(fit).append(new Option(name, spec));
  }
  picker.addEventListener("change", () => {
    if (!picker.value) return;
    box.value = picker.value;
    box.dispatchEvent(new KeyboardEvent("keydown", { key: "Enter", bubbles: true }));
    picker.value = "";
  });
  box.after(picker);
  return picker;
}
