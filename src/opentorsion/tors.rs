//! TORS files: read as OpenTorsion's parser reads them, their components laid on the nodes
//! (walked without recursion), and [`convert`], the front door of both file forms.

use super::locate::locate_json;
use super::{Assembly, Disk, Gear, Shaft};
use crate::error::{Error, Location, Result};
use crate::io::line_col;
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;

/// A TORS file as OpenTorsion's parser reads it (other fields are ignored).
#[derive(Debug, Deserialize)]
struct Tors {
    #[serde(default)]
    structure: Vec<(String, String)>,
    components: Vec<Component>,
}

#[derive(Debug, Deserialize)]
struct Component {
    name: String,
    elements: Vec<Element>,
}

/// One element as written: every type's fields, checked against its `type` when it is laid on
/// the nodes (so that a missing or misspelt field is reported at the element, with its name).
#[derive(Debug, Deserialize)]
#[allow(non_snake_case)]
struct Element {
    name: String,
    #[serde(rename = "type")]
    kind: String,
    inertia: Option<f64>,
    damping: Option<f64>,
    stiffness: Option<f64>,
    length: Option<f64>,
    innerDiameter: Option<f64>,
    outerDiameter: Option<f64>,
    density: Option<f64>,
    teeth: Option<f64>,
    diameter: Option<f64>,
    parent: Option<String>,
    excitation: Option<serde_json::Value>,
}

/// OpenTorsion's default shear modulus for a shaft given by its geometry, Pa.
const SHEAR_MODULUS: f64 = 80e9;
/// OpenTorsion's default density, kg/m³.
const DENSITY: f64 = 8000.0;

/// An input error at a JSON field path, located in `text` (line:column of the value, or of the
/// nearest enclosing one).
fn json_error(file: &Path, text: &str, path: &str, message: impl Into<String>) -> Error {
    let line_col = Some(line_col(text, locate_json(text, path)));
    Error::Input {
        location: Location { file: file.to_path_buf(), line_col, path: path.to_string() },
        message: message.into(),
    }
}

/// Deserializes JSON text with serde's field path and serde_json's line:column.
fn parse_json<T: serde::de::DeserializeOwned>(file: &Path, text: &str) -> Result<T> {
    let located = |path: String, inner: serde_json::Error| {
        let line_col = (inner.line() > 0).then(|| (inner.line(), inner.column()));
        // serde_json appends " at line L column C"; the location says it already.
        let message = inner.to_string();
        let message = message.split(" at line ").next().unwrap_or(&message).to_string();
        Error::Input { location: Location { file: file.to_path_buf(), line_col, path }, message }
    };
    let mut de = serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        located(path, e.into_inner())
    })?;
    de.end().map_err(|e| located(String::new(), e))?;
    Ok(value)
}

/// Reads a TORS JSON text (`file` names it in messages) into the node description OpenTorsion's
/// `Parser.from_tors` builds, with the TORS path of each element (`components[c].elements[e]`)
/// for messages.
fn from_tors(file: &Path, text: &str) -> Result<TorsBuilder> {
    let tors: Tors = parse_json(file, text)?;
    let err = |path: &str, message: String| json_error(file, text, path, message);
    if tors.components.is_empty() {
        return Err(err("components", "no components".to_string()));
    }
    let mut by_name: HashMap<&str, usize> = HashMap::new();
    for (c, comp) in tors.components.iter().enumerate() {
        if let Some(prev) = by_name.insert(comp.name.as_str(), c) {
            return Err(err(
                &format!("components[{c}].name"),
                format!("duplicate component name `{}` (also components[{prev}])", comp.name),
            ));
        }
    }
    // Connections: `A.element` → component B.
    let mut next: BTreeMap<(usize, String), (usize, usize)> = BTreeMap::new();
    let mut into: HashSet<usize> = HashSet::new();
    let mut from: Vec<usize> = Vec::new();
    let split = |s: &str, path: &str| -> Result<(usize, String)> {
        let (comp, elem) = s.split_once('.').unwrap_or((s, ""));
        match by_name.get(comp) {
            Some(&c) => Ok((c, elem.to_string())),
            None => Err(err(
                path,
                format!(
                    "unknown component `{comp}` (components: {})",
                    tors.components.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ")
                ),
            )),
        }
    };
    for (k, (a, b)) in tors.structure.iter().enumerate() {
        let (ca, ea) = split(a, &format!("structure[{k}][0]"))?;
        let (cb, _) = split(b, &format!("structure[{k}][1]"))?;
        if !tors.components[ca].elements.iter().any(|e| e.name == ea) {
            return Err(err(
                &format!("structure[{k}][0]"),
                format!("component `{}` has no element `{ea}`", tors.components[ca].name),
            ));
        }
        if !into.insert(cb) {
            return Err(err(
                &format!("structure[{k}][1]"),
                format!("component `{}` is connected into twice", tors.components[cb].name),
            ));
        }
        next.insert((ca, ea), (cb, k));
        from.push(ca);
    }
    let starts: Vec<usize> = {
        let mut s: Vec<usize> = from.iter().copied().filter(|c| !into.contains(c)).collect();
        s.sort_unstable();
        s.dedup();
        s
    };
    let start = match starts.as_slice() {
        [s] => *s,
        [] if tors.components.len() == 1 => 0,
        [] => {
            return Err(err(
                "structure",
                "no component to start from: every connected component is connected into (a loop?)".to_string(),
            ));
        }
        [_, _, ..] => {
            return Err(err(
                "structure",
                "more than one group of connected components (the model must be one assembly)".to_string(),
            ));
        }
    };

    let mut b = TorsBuilder::default();
    let mut visited = vec![false; tors.components.len()];
    b.walk(&tors, start, &next, &mut visited, &err)?;
    if let Some(c) = visited.iter().position(|v| !v) {
        return Err(err(
            &format!("components[{c}]"),
            format!("component `{}` is not connected to the assembly", tors.components[c].name),
        ));
    }
    Ok(b)
}

/// The node numbering of a TORS file, element by element: the assembly and the TORS path
/// (`components[c].elements[e]`) of each of its shafts, disks and gears.
#[derive(Default)]
struct TorsBuilder {
    node: usize,
    assembly: Assembly,
    shaft_paths: Vec<String>,
    disk_paths: Vec<String>,
    gear_paths: Vec<String>,
    /// Gear index by `component.element`.
    gear_index: HashMap<String, usize>,
}

impl TorsBuilder {
    /// Lays the components on the nodes from `start` as OpenTorsion does: a component's
    /// elements in order, and after an element that a connection leaves from, the whole
    /// component it leads to (and what that one leads to) before the next element. A stack of
    /// (component, next element), not recursion: a chain of 12,300 components overflowed the
    /// stack (issue 49).
    fn walk(
        &mut self,
        tors: &Tors,
        start: usize,
        next: &BTreeMap<(usize, String), (usize, usize)>,
        visited: &mut [bool],
        err: &dyn Fn(&str, String) -> Error,
    ) -> Result<()> {
        visited[start] = true;
        let mut stack = vec![(start, 0usize)];
        while let Some((c, e)) = stack.pop() {
            let Some(element) = tors.components[c].elements.get(e) else { continue };
            stack.push((c, e + 1));
            self.element(tors, c, e, err)?;
            if let Some(&(to, k)) = next.get(&(c, element.name.clone())) {
                if visited[to] {
                    return Err(err(
                        &format!("structure[{k}][1]"),
                        format!(
                            "component `{}` is reached twice (the connections form a loop)",
                            tors.components[to].name
                        ),
                    ));
                }
                visited[to] = true;
                stack.push((to, 0));
            }
        }
        Ok(())
    }

    /// Lays element `e` of component `c` on the nodes.
    fn element(&mut self, tors: &Tors, c: usize, e: usize, err: &dyn Fn(&str, String) -> Error) -> Result<()> {
        let comp = &tors.components[c];
        let element = &comp.elements[e];
        let path = format!("components[{c}].elements[{e}]");
        let id = format!("{}.{}", comp.name, element.name);
        if element.excitation.is_some() {
            self.assembly.excited.push(id.clone());
        }
        let need = |value: Option<f64>, field: &str| {
            value.ok_or_else(|| err(&path, format!("{} `{id}` has no `{field}`", element.kind)))
        };
        let damping = element.damping.unwrap_or(0.0);
        match element.kind.as_str() {
            "Disk" => {
                let inertia = need(element.inertia, "inertia")?;
                // OpenTorsion adds a disk to the previous one when both are on this node.
                match self.assembly.disks.last_mut() {
                    Some(last) if last.node == self.node => {
                        last.inertia += inertia;
                        last.c += damping;
                    }
                    _ => {
                        self.assembly.disks.push(Disk { node: self.node, inertia, c: damping, k: 0.0 });
                        self.disk_paths.push(path.clone());
                    }
                }
            }
            "ShaftDiscrete" => {
                let k = need(element.stiffness, "stiffness")?;
                self.assembly.shafts.push(Shaft { nl: self.node, nr: self.node + 1, k, c: damping, mass: 0.0 });
                self.shaft_paths.push(path.clone());
                self.node += 1;
            }
            "ShaftContinuous" => {
                // mm to m; polar second moment of area J, stiffness G·J/L and the mass factor
                // ρ·J·L/6. OpenTorsion gives such a shaft no damping.
                let l = need(element.length, "length")? * 1e-3;
                let d = need(element.outerDiameter, "outerDiameter")? * 1e-3;
                let di = element.innerDiameter.unwrap_or(0.0) * 1e-3;
                let j = std::f64::consts::PI * (d.powi(4) - di.powi(4)) / 32.0;
                if !(l > 0.0 && j > 0.0 && di >= 0.0) {
                    return Err(err(
                        &format!("{path}.length"),
                        format!("shaft `{id}`: length and outer diameter must be positive, outer above inner (mm)"),
                    ));
                }
                let rho = element.density.unwrap_or(DENSITY);
                let (k, mass) = (SHEAR_MODULUS * j / l, rho * j * l / 6.0);
                self.assembly.shafts.push(Shaft { nl: self.node, nr: self.node + 1, k, c: 0.0, mass });
                self.shaft_paths.push(path.clone());
                self.node += 1;
            }
            "GearElement" => {
                let inertia = need(element.inertia, "inertia")?;
                let Some(radius) = element.teeth.or(element.diameter) else {
                    return Err(err(&path, format!("gear `{id}` has neither `teeth` nor `diameter`")));
                };
                let parent = match &element.parent {
                    None => None,
                    Some(p) => match self.gear_index.get(&format!("{}.{p}", comp.name)) {
                        Some(&g) => {
                            // A gear driven by a parent sits on a node of its own.
                            self.node += 1;
                            Some(g)
                        }
                        None => {
                            return Err(err(
                                &format!("{path}.parent"),
                                format!(
                                    "gear `{id}`: parent `{p}` is not a gear listed before it in component `{}`",
                                    comp.name
                                ),
                            ));
                        }
                    },
                };
                self.gear_index.insert(id.clone(), self.assembly.gears.len());
                self.assembly.gears.push(Gear { node: self.node, inertia, radius, parent });
                self.gear_paths.push(path.clone());
            }
            other => {
                return Err(err(
                    &format!("{path}.type"),
                    format!(
                        "unknown element type `{other}` (TORS types: Disk, ShaftDiscrete, ShaftContinuous, GearElement)"
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Converts an OpenTorsion model file (a TORS JSON assembly, or the node form [`Assembly`]
/// that `kanedyn.from_opentorsion` uses) to mechanism RON named `name`; errors name the file,
/// line:column and field.
pub fn convert(file: &Path, text: &str, name: &str) -> Result<String> {
    // A UTF-8 byte-order mark, as some Windows editors write, is not JSON but means nothing.
    let text = text.strip_prefix('\u{FEFF}').unwrap_or(text);
    // The node form has `shafts`, `disks` or `gears` at the top; a TORS file `components`.
    let top: serde_json::Value = parse_json(file, text)?;
    let object = top.as_object();
    // Neither form's keys: say so rather than read it as a node form with unknown fields (issue
    // 49: a TORS file without `components` was read as a node form).
    let node_key = |k: &String| matches!(k.as_str(), "shafts" | "disks" | "gears" | "excited");
    if let Some(o) = object.filter(|o| !o.is_empty() && !o.contains_key("components") && !o.keys().any(node_key)) {
        let keys: Vec<String> = o.keys().map(|k| format!("`{}`", k.escape_debug())).collect();
        let (path, message) = if o.contains_key("structure") {
            ("structure", "a TORS file (it has `structure`) without `components`, which list its elements".to_string())
        } else {
            (
                "",
                format!(
                    "neither a TORS file (`components`) nor kanedyn's node form (`shafts`, `disks`, `gears`): its \
                     keys are {}",
                    keys.join(", ")
                ),
            )
        };
        return Err(json_error(file, text, path, message));
    }
    let node_form = object.is_some_and(|o| !o.contains_key("components"));
    if node_form {
        let assembly: Assembly = parse_json(file, text)?;
        assembly.to_ron(name).map_err(|p| json_error(file, text, &p.path, p.message))
    } else {
        let tors = from_tors(file, text)?;
        tors.assembly.to_ron(name).map_err(|p| {
            // The node form's path in TORS terms: the element, and its field under TORS's name.
            let (list, rest) = p.path.split_once('[').unwrap_or(("", ""));
            let (index, field) = rest.split_once(']').unwrap_or(("", ""));
            let paths = match list {
                "shafts" => &tors.shaft_paths,
                "disks" => &tors.disk_paths,
                "gears" => &tors.gear_paths,
                _ => return json_error(file, text, "", p.message),
            };
            let element = index.parse::<usize>().ok().and_then(|i| paths.get(i)).cloned().unwrap_or_default();
            // The node form's own fields (nodes, the mass factor, the parent's index, the radius
            // that is a diameter or a tooth count) are the element itself in TORS terms.
            let path = match field.trim_start_matches('.') {
                "k" => format!("{element}.stiffness"),
                "c" => format!("{element}.damping"),
                "inertia" => format!("{element}.inertia"),
                _ => element,
            };
            json_error(file, text, &path, p.message)
        })
    }
}
