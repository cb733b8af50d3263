//! The config reference page (docs/src/config.md), rendered from the JSON schemas that the config
//! types derive (`schemars::JsonSchema`: their doc comments, serde renames, tags and defaults), so
//! the page says what the deserializer accepts. `page()` returns the Markdown and the keys that
//! have no doc comment; `tests/it/config_reference.rs` checks the committed page against it.

use serde_json::{Map, Value};
use std::collections::{BTreeMap, VecDeque};

/// The command that rewrites the page.
pub const COMMAND: &str =
    "cargo run -q -p camsim-cli --example config-reference > docs/src/config.md";

const PREAMBLE: &str = "# Config reference

<!-- Generated from the config types' doc comments by
`cargo run -q -p camsim-cli --example config-reference > docs/src/config.md`;
crates/camsim-cli/tests/it/config_reference.rs fails when this file differs. Edit the doc comments,
not this file. -->

`camsim simulate CONFIG.toml` reads one TOML file; `examples/` has one per scene kind
(`macbeth-d65.toml` is the built-in default, `uniform.toml`, `slanted-edge.toml`,
`radiance-file.toml`, `cornell-box.toml`). Unknown keys are errors. Paths are relative to the
config file. `camsim simulate --print-config` prints the effective config; every run writes it
back in `run.json`, and `camsim simulate DIR/run.json` repeats the run. A `preset` with
`[optics.config]` or `[sensor.config]` keys is the preset with those keys replaced (tables merge
key by key; unknown keys are refused by name).

Each table below lists a TOML table's keys (in alphabetical order), their type, their default
(\"required\" where there is none and the key must be given, \"-\" where leaving it out has the
meaning the description gives) and what they mean.
";

/// One schema to document: its title, the sentence that introduces it and the schema itself.
pub struct Part {
    pub title: &'static str,
    pub intro: &'static str,
    pub root_path: &'static str,
    pub schema: Value,
}

/// The parts of the page: the simulate config, the overlay file, the dataset spec.
pub fn parts() -> Vec<Part> {
    let json = |s: schemars::Schema| serde_json::to_value(s).expect("a schema is JSON");
    vec![
        Part {
            title: "Simulate config",
            intro: "`camsim simulate CONFIG.toml`, Python's `camsim.simulate(config)`, and each \
                    dataset sample's config. Give exactly one of `[scene]` (a 2D chart) and \
                    `[render]` (a 3D scene).",
            root_path: "",
            schema: json(schemars::schema_for!(camsim::pipeline::SimulateConfig)),
        },
        Part {
            title: "Scene overlay",
            intro: "An overlay file (`camsim render --overlay FILE`, `[render] overlay`, or the \
                    same tables inline under `[render.overlay_inline]`) changes a 3D scene after \
                    it is read: the camera, objects, materials, the light. Examples in \
                    `examples/overlays/`.",
            root_path: "",
            schema: json(schemars::schema_for!(camsim::pbrt::overlay::Overlay)),
        },
        Part {
            title: "Dataset spec",
            intro: "`camsim dataset SPEC.toml`: a base simulate config and the variations drawn \
                    for each sample (examples in `examples/datasets/`).",
            root_path: "",
            schema: json(schemars::schema_for!(camsim::dataset::spec::SpecFile)),
        },
    ]
}

/// The page's Markdown, and the keys (and enum values) that have no doc comment.
pub fn page() -> (String, Vec<String>) {
    let mut out = String::from(PREAMBLE);
    let mut missing = Vec::new();
    for part in parts() {
        out.push_str(&format!("\n## {}\n\n{}\n", part.title, part.intro));
        let mut r = Renderer {
            defs: part
                .schema
                .get("$defs")
                .and_then(Value::as_object)
                .cloned()
                .unwrap_or_default(),
            queue: VecDeque::new(),
            seen: BTreeMap::new(),
            out: String::new(),
            missing: Vec::new(),
            anchor_prefix: slug(part.title),
            anchors: Vec::new(),
            in_array: false,
            alternative: false,
        };
        r.table(part.schema.clone(), part.root_path, None);
        while let Some(item) = r.queue.pop_front() {
            r.section(item);
        }
        out.push_str(&r.out);
        missing.extend(r.missing);
    }
    (out, missing)
}

struct Item {
    schema: Value,
    path: String,
    def: Option<String>,
    /// An array of tables (`[[path]]`).
    array: bool,
    /// One of several alternative forms of the key at `path` (its heading names its keys).
    alternative: bool,
    anchor: String,
}

struct Renderer {
    defs: Map<String, Value>,
    queue: VecDeque<Item>,
    /// Definition name -> the TOML path, array flag and anchor of the section that documents it.
    seen: BTreeMap<String, (String, bool, String)>,
    out: String,
    missing: Vec<String>,
    anchor_prefix: String,
    /// Anchors given out so far (two alternatives of one key get their own).
    anchors: Vec<String>,
    /// Whether the table being typed is an array of tables.
    in_array: bool,
    /// Whether the table being queued is one of several alternative forms of one key.
    alternative: bool,
}

fn slug(s: &str) -> String {
    let mut out = String::new();
    for c in s.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('-') {
            out.push('-');
        }
    }
    out.trim_matches('-').to_string()
}

/// A doc comment as one table cell: lines joined, `|` escaped, rustdoc links made plain code.
fn cell(text: &str) -> String {
    let joined = text
        .split('\n')
        .map(str::trim)
        .collect::<Vec<_>>()
        .join(" ");
    let mut s = joined.replace('|', "\\|");
    // [`crate::x`] (an intra-doc link) -> `crate::x`.
    while let Some(i) = s.find("[`") {
        let Some(j) = s[i..].find("`]") else { break };
        let end = i + j + 2;
        if s[end..].starts_with('(') {
            break;
        }
        s = format!("{}{}{}", &s[..i], &s[i + 1..end - 1], &s[end..]);
    }
    s
}

/// A JSON value written as TOML (inline).
fn toml_value(v: &Value) -> String {
    match v {
        Value::Null => "-".into(),
        Value::String(s) => format!("\"{s}\""),
        Value::Array(a) => format!(
            "[{}]",
            a.iter().map(toml_value).collect::<Vec<_>>().join(", ")
        ),
        Value::Object(o) if o.is_empty() => "{}".into(),
        Value::Object(o) => format!(
            "{{ {} }}",
            o.iter()
                .map(|(k, v)| format!("{k} = {}", toml_value(v)))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        other => other.to_string(),
    }
}

fn description(s: &Value) -> Option<&str> {
    s.get("description").and_then(Value::as_str)
}

fn join_path(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

impl Renderer {
    /// `Some((key, inner))` when `alt` is an externally tagged enum variant whose value is a
    /// table: an object with exactly one property, itself a table. The inner table gets the
    /// variant's doc comment where it has none of its own.
    fn externally_tagged(&self, alt: &Value) -> Option<(String, Value)> {
        let props = alt.get("properties")?.as_object()?;
        if props.len() != 1 {
            return None;
        }
        let (key, inner) = props.iter().next()?;
        let resolved = match inner.get("$ref").and_then(Value::as_str) {
            Some(r) => self.def(r).1,
            None => inner.clone(),
        };
        resolved.get("properties")?;
        let mut inner = inner.clone();
        if let (None, Some(d)) = (description(&resolved), description(alt)) {
            // A `$ref` with a description beside it keeps the reference (and its section).
            inner["description"] = Value::String(d.to_string());
        }
        Some((key.clone(), inner))
    }

    fn def(&self, reference: &str) -> (String, Value) {
        let name = reference.trim_start_matches("#/$defs/").to_string();
        let schema = self.defs.get(&name).cloned().unwrap_or(Value::Null);
        (name, schema)
    }

    /// `schema` without its `null` alternative (an `Option`), and whether there was one.
    fn unwrap_null(schema: &Value) -> Value {
        if let Some(alts) = schema.get("anyOf").and_then(Value::as_array) {
            let non_null: Vec<&Value> = alts
                .iter()
                .filter(|a| a.get("type").and_then(Value::as_str) != Some("null"))
                .collect();
            if non_null.len() == 1 && alts.len() == 2 {
                return non_null[0].clone();
            }
        }
        if let Some(types) = schema.get("type").and_then(Value::as_array) {
            let non_null: Vec<&Value> = types.iter().filter(|t| *t != "null").collect();
            if non_null.len() == 1 {
                let mut s = schema.clone();
                s["type"] = non_null[0].clone();
                return s;
            }
        }
        schema.clone()
    }

    /// A new anchor for the table at `path`.
    fn anchor(&mut self, path: &str) -> String {
        let base = format!(
            "{}-{}",
            self.anchor_prefix,
            slug(if path.is_empty() { "top" } else { path })
        );
        let mut anchor = base.clone();
        let mut n = 1;
        while self.anchors.contains(&anchor) {
            n += 1;
            anchor = format!("{base}-{n}");
        }
        self.anchors.push(anchor.clone());
        anchor
    }

    fn link(path: &str, array: bool, anchor: &str) -> String {
        if array {
            format!("[`[[{path}]]`](#{anchor})")
        } else {
            format!("[`[{path}]`](#{anchor})")
        }
    }

    /// A table to document at `path`: queued once per definition; returns its link.
    fn table(&mut self, schema: Value, path: &str, def: Option<String>) -> String {
        let array = self.in_array;
        if let Some(name) = &def {
            if let Some((first, array, anchor)) = self.seen.get(name) {
                return Self::link(first, *array, anchor);
            }
        }
        let anchor = self.anchor(path);
        if let Some(name) = &def {
            self.seen
                .insert(name.clone(), (path.to_string(), array, anchor.clone()));
        }
        self.queue.push_back(Item {
            schema,
            path: path.to_string(),
            def,
            array,
            alternative: self.alternative,
            anchor: anchor.clone(),
        });
        Self::link(path, array, &anchor)
    }

    /// The type column for `schema` at `path`, queueing the tables it contains; and the notes
    /// (enum values' own doc comments) for the description column.
    fn type_of(&mut self, schema: &Value, path: &str) -> (String, Vec<String>) {
        let schema = Self::unwrap_null(schema);
        if let Some(r) = schema.get("$ref").and_then(Value::as_str) {
            let (name, def) = self.def(r);
            return self.type_of_def(&name, &def, path);
        }
        self.type_of_def("", &schema, path)
    }

    fn type_of_def(&mut self, name: &str, schema: &Value, path: &str) -> (String, Vec<String>) {
        let def = (!name.is_empty()).then(|| name.to_string());
        if let Some(alts) = schema
            .get("oneOf")
            .or_else(|| schema.get("anyOf"))
            .and_then(Value::as_array)
        {
            let alts = alts.clone();
            // A tagged enum (`kind = "..."`): a table per variant.
            if tag_of(&alts).is_some() {
                let link = self.table(schema.clone(), path, def);
                return (format!("table, see {link}"), vec![]);
            }
            let mut types = Vec::new();
            let mut notes = Vec::new();
            for alt in &alts {
                if let Some(c) = alt.get("const") {
                    types.push(format!("`{}`", toml_value(c)));
                    match description(alt) {
                        Some(d) => notes.push(format!(
                            "`{}`: {}",
                            toml_value(c),
                            cell(d).trim_end_matches('.')
                        )),
                        None => self
                            .missing
                            .push(format!("{path} = {} (enum value)", toml_value(c))),
                    }
                } else if let Some((key, inner)) = self.externally_tagged(alt) {
                    // An externally tagged variant `{ key = { ... } }`: the inner table is
                    // documented at `path.key` (no section for the one-key wrapper).
                    let (t, _) = self.type_of(&inner, &join_path(path, &key));
                    let link = t.trim_start_matches("table, see ");
                    // Its doc comment heads the linked section.
                    types.push(format!("`{{ {key} = {{ ... }} }}` ({link})"));
                } else if alt.get("properties").is_some() {
                    // An untagged alternative: a table of its own keys at the same path.
                    self.alternative = true;
                    let link = self.table(alt.clone(), path, None);
                    self.alternative = false;
                    types.push(format!("table ({link})"));
                } else {
                    // A table here is one of several forms of the key (its heading names its keys).
                    self.alternative = true;
                    let (t, n) = self.type_of(alt, path);
                    self.alternative = false;
                    // (An inner enum's values carry their own notes.)
                    if let (Some(d), true) = (description(alt), n.is_empty()) {
                        notes.push(format!("{t}: {}", cell(d).trim_end_matches('.')));
                    }
                    types.push(t);
                    notes.extend(n);
                }
            }
            types.dedup();
            return (types.join(" or "), notes);
        }
        match schema.get("type").and_then(Value::as_str) {
            Some("object") => {
                if schema.get("properties").is_some() {
                    let link = self.table(schema.clone(), path, def);
                    (format!("table, see {link}"), vec![])
                } else {
                    let value = match schema.get("additionalProperties") {
                        Some(v @ Value::Object(_)) => self.type_of(v, &join_path(path, "NAME")).0,
                        _ => "any value".into(),
                    };
                    (format!("table of `NAME = {value}`"), vec![])
                }
            }
            Some("array") => {
                let n = schema.get("minItems").and_then(Value::as_u64);
                let fixed = n.is_some() && n == schema.get("maxItems").and_then(Value::as_u64);
                let (item, notes) = match schema.get("items") {
                    Some(items) => {
                        let inner = Self::unwrap_null(items);
                        let is_table = inner.get("$ref").is_some_and(|r| {
                            let (_, d) = self.def(r.as_str().unwrap_or_default());
                            d.get("properties").is_some()
                        }) || inner.get("properties").is_some();
                        if is_table {
                            // `[[path]]`: an array of tables.
                            self.in_array = true;
                            let (t, n) = self.type_of(items, path);
                            self.in_array = false;
                            return (
                                format!("array of tables ({})", t.replace("table, see ", "")),
                                n,
                            );
                        }
                        self.type_of(items, path)
                    }
                    None => ("any value".into(), vec![]),
                };
                let plural = if item.starts_with('`') {
                    item
                } else if let Some(rest) = item.strip_prefix("array of ") {
                    format!("arrays of {rest}")
                } else {
                    format!("{item}s")
                };
                let text = match (fixed, n) {
                    (true, Some(n)) => format!("array of {n} {plural}"),
                    _ => format!("array of {plural}"),
                };
                (text, notes)
            }
            Some(t) => {
                let t = match t {
                    "string" if schema.get("const").is_some() => {
                        format!("`{}`", toml_value(&schema["const"]))
                    }
                    "integer" | "number" | "string" | "boolean" => t.to_string(),
                    other => other.to_string(),
                };
                (t, vec![])
            }
            None if schema
                .as_object()
                .is_some_and(|o| o.keys().all(|k| k == "description" || k == "default")) =>
            {
                ("any value".into(), vec![])
            }
            None => ("any value".into(), vec![]),
        }
    }

    fn section(&mut self, item: Item) {
        let schema = item.schema;
        let heading = if item.path.is_empty() {
            "top level".to_string()
        } else {
            let base = if item.array {
                format!("`[[{}]]`", item.path)
            } else {
                format!("`[{}]`", item.path)
            };
            let keys: Vec<String> = schema
                .get("required")
                .and_then(Value::as_array)
                .map(|r| {
                    r.iter()
                        .filter_map(Value::as_str)
                        .map(|k| format!("`{k}`"))
                        .collect()
                })
                .unwrap_or_default();
            if item.alternative && !keys.is_empty() {
                format!("{base} with {}", keys.join(", "))
            } else {
                base
            }
        };
        self.out.push_str(&format!(
            "\n<a id=\"{}\"></a>\n\n### {heading}\n\n",
            item.anchor
        ));
        if let Some(d) = description(&schema) {
            self.out.push_str(&cell(d));
            self.out.push_str("\n\n");
        } else if !item.path.is_empty() {
            let name = item.def.clone().unwrap_or_else(|| item.path.clone());
            self.missing
                .push(format!("[{}] (the type {name})", item.path));
        }
        if let Some(alts) = schema
            .get("oneOf")
            .or_else(|| schema.get("anyOf"))
            .and_then(Value::as_array)
        {
            let alts = alts.clone();
            if let Some(tag) = tag_of(&alts) {
                for alt in &alts {
                    let value = toml_value(&alt["properties"][&tag]["const"]);
                    self.out.push_str(&format!("#### `{tag} = {value}`\n\n"));
                    // Where the key's values come from a name table, its description of the
                    // value (what `camsim presets` prints); else the variant's doc comment.
                    let about = alt["properties"][&tag]["const"]
                        .as_str()
                        .and_then(|v| named_about(&join_path(&item.path, &tag), v));
                    let text = match about {
                        Some(a) => Some(format!("{}.", capitalized(a))),
                        None => description(alt).map(cell),
                    };
                    match text {
                        Some(d) => {
                            self.out.push_str(&d);
                            self.out.push_str("\n\n");
                        }
                        None => self
                            .missing
                            .push(format!("[{}] {tag} = {value} (enum variant)", item.path)),
                    }
                    self.rows(alt, &item.path, Some(&tag));
                    self.out.push('\n');
                }
                return;
            }
        }
        self.rows(&schema, &item.path, None);
    }

    fn rows(&mut self, schema: &Value, path: &str, skip: Option<&str>) {
        let Some(props) = schema.get("properties").and_then(Value::as_object) else {
            return;
        };
        let required: Vec<&str> = schema
            .get("required")
            .and_then(Value::as_array)
            .map(|r| r.iter().filter_map(Value::as_str).collect())
            .unwrap_or_default();
        self.out
            .push_str("| key | type | default | meaning |\n|---|---|---|---|\n");
        for (key, prop) in props {
            if Some(key.as_str()) == skip {
                continue;
            }
            let key_path = join_path(path, key);
            let (ty, notes) = self.type_of(prop, &key_path);
            let default = match prop.get("default") {
                Some(v) if ty.starts_with("table, see") || v.is_null() => "-".to_string(),
                Some(v) => format!("`{}`", toml_value(v).replace('|', "\\|")),
                None if required.contains(&key.as_str()) => "required".into(),
                None => "-".into(),
            };
            let mut meaning = match description(prop) {
                Some(d) => cell(d),
                None => {
                    self.missing.push(key_path.clone());
                    String::new()
                }
            };
            if !notes.is_empty() {
                meaning.push_str(&format!(" Values: {}.", notes.join("; ")));
            }
            if let Some(names) = named_values(&key_path) {
                meaning.push_str(&format!(" Names: {names}."));
            }
            self.out.push_str(&format!(
                "| `{key}` | {} | {default} | {} |\n",
                ty.replace('|', "\\|"),
                meaning.trim()
            ));
        }
    }
}

/// Keys whose values are names from a table camsim dispatches on (the `camsim presets` catalogue),
/// and that table's family.
const NAMED_KEYS: &[(&str, &str)] = &[
    ("optics.preset", "lens presets"),
    ("sensor.preset", "sensor presets"),
    ("render.builtin", "3D scenes"),
    ("sensor.config.cfa", "colour filter arrays"),
    ("dataset.outputs", "dataset outputs"),
    ("scene.kind", "2D scene kinds"),
];

/// The catalogue's description of `name` for a key of [`NAMED_KEYS`].
fn named_about(key_path: &str, name: &str) -> Option<&'static str> {
    let (_, family) = NAMED_KEYS.iter().find(|(k, _)| *k == key_path)?;
    camsim::names::catalogue()
        .into_iter()
        .find(|f| f.title == *family)?
        .entries
        .into_iter()
        .find(|(n, _)| *n == name)
        .map(|(_, about)| about)
}

fn capitalized(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().chain(c).collect(),
        None => String::new(),
    }
}

/// The names a key takes, from the catalogue (so the page lists exactly what the code accepts).
fn named_values(key_path: &str) -> Option<String> {
    let (_, family) = NAMED_KEYS.iter().find(|(k, _)| *k == key_path)?;
    let catalogue = camsim::names::catalogue();
    let f = catalogue.iter().find(|f| f.title == *family)?;
    Some(
        f.entries
            .iter()
            .map(|(name, about)| format!("`{name}` ({about})"))
            .collect::<Vec<_>>()
            .join(", "),
    )
}

/// The tag key of an internally tagged enum: a key that every alternative has as a constant.
fn tag_of(alts: &[Value]) -> Option<String> {
    let first = alts.first()?.get("properties")?.as_object()?;
    first
        .iter()
        .find(|(k, v)| {
            v.get("const").is_some()
                && alts.iter().all(|a| {
                    a.get("properties")
                        .and_then(|p| p.get(k.as_str()))
                        .and_then(|p| p.get("const"))
                        .is_some()
                })
        })
        .map(|(k, _)| k.clone())
        .filter(|_| alts.len() > 1)
}
