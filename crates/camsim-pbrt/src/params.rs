//! Parameter lists: `"type name" value` or `"type name" [ values ]`, with pbrt-v4's types and
//! its rule that every parameter a directive is given must be used (an unknown or mistyped
//! parameter is an error, as pbrt-v4's `ReportUnused` makes it).

use super::lexer::{Token, TokenKind};
use super::{Loc, PbrtError};
use std::cell::Cell;

/// One value inside a parameter's list.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Num(f64),
    Str(String),
    Bool(bool),
}

/// One parameter as written.
#[derive(Debug, Clone)]
pub struct Param {
    /// Declared type, normalised (`point` -> `point3`, `vector` -> `vector3`, `normal` ->
    /// `normal3`, `color` -> `rgb`).
    pub ty: String,
    pub name: String,
    pub values: Vec<Value>,
    pub loc: Loc,
    pub used: Cell<bool>,
}

/// Types pbrt-v4 knows.
const TYPES: &[&str] = &[
    "integer",
    "float",
    "point2",
    "vector2",
    "point3",
    "vector3",
    "normal3",
    "bool",
    "string",
    "texture",
    "rgb",
    "spectrum",
    "blackbody",
];

/// A directive's parameter list.
#[derive(Debug, Clone, Default)]
pub struct ParamList {
    pub params: Vec<Param>,
}

impl Param {
    pub fn nums(&self) -> Result<Vec<f64>, PbrtError> {
        self.values
            .iter()
            .map(|v| match v {
                Value::Num(x) => Ok(*x),
                _ => Err(self.loc.err(format!(
                    "parameter \"{}\" ({}) needs numbers",
                    self.name, self.ty
                ))),
            })
            .collect()
    }
    pub fn strings(&self) -> Result<Vec<String>, PbrtError> {
        self.values
            .iter()
            .map(|v| match v {
                Value::Str(s) => Ok(s.clone()),
                _ => Err(self.loc.err(format!(
                    "parameter \"{}\" ({}) needs quoted strings",
                    self.name, self.ty
                ))),
            })
            .collect()
    }
}

/// Parse a parameter list starting at `tokens[*pos]`: stops at the first token that is not a
/// quoted string (the next directive).
pub fn parse_params(
    tokens: &[Token],
    pos: &mut usize,
    file: &std::path::Path,
) -> Result<ParamList, PbrtError> {
    let mut list = ParamList::default();
    while let Some(tok) = tokens.get(*pos) {
        if let TokenKind::ObjectName(_) = tok.kind {
            // A naming comment between parameters names nothing: skip it.
            if matches!(
                tokens.get(*pos + 1).map(|t| &t.kind),
                Some(TokenKind::Str(_))
            ) {
                *pos += 1;
                continue;
            }
            break;
        }
        let TokenKind::Str(decl) = &tok.kind else {
            break;
        };
        let loc = Loc {
            file: file.to_path_buf(),
            line: tok.line,
            column: tok.column,
        };
        let mut parts = decl.split_whitespace();
        let (Some(ty), Some(name), None) = (parts.next(), parts.next(), parts.next()) else {
            return Err(loc.err(format!(
                "expected a parameter declaration \"type name\", found \"{decl}\" (a quoted string where a directive \
                 or parameter was expected)"
            )));
        };
        let ty = match ty {
            "point" => "point3",
            "vector" => "vector3",
            "normal" => "normal3",
            "color" => "rgb",
            t => t,
        }
        .to_string();
        if !TYPES.contains(&ty.as_str()) {
            return Err(loc.err(format!("unknown parameter type \"{ty}\" in \"{decl}\"")));
        }
        *pos += 1;
        let mut values = Vec::new();
        let parse_value = |t: &Token| -> Result<Value, PbrtError> {
            let vloc = Loc {
                file: file.to_path_buf(),
                line: t.line,
                column: t.column,
            };
            match &t.kind {
                TokenKind::Str(s) => {
                    if ty == "bool" {
                        match s.as_str() {
                            "true" => Ok(Value::Bool(true)),
                            "false" => Ok(Value::Bool(false)),
                            _ => Err(vloc.err(format!("\"{s}\" is not a bool (true or false)"))),
                        }
                    } else {
                        Ok(Value::Str(s.clone()))
                    }
                }
                TokenKind::Word(w) => match w.as_str() {
                    "true" => Ok(Value::Bool(true)),
                    "false" => Ok(Value::Bool(false)),
                    _ => match w.parse::<f64>() {
                        Ok(x) if x.is_finite() => Ok(Value::Num(x)),
                        _ => Err(vloc.err(format!("\"{w}\" is not a number"))),
                    },
                },
                _ => Err(vloc.err(format!(
                    "unexpected \"{}\" in a parameter value",
                    t.describe()
                ))),
            }
        };
        match tokens.get(*pos) {
            None => return Err(loc.err(format!("parameter \"{name}\" has no value (end of file)"))),
            Some(t) if t.kind == TokenKind::Open => {
                *pos += 1;
                loop {
                    match tokens.get(*pos) {
                        None => {
                            return Err(loc.err(format!(
                                "parameter \"{name}\": missing ']' before end of file"
                            )))
                        }
                        Some(t) if t.kind == TokenKind::Close => {
                            *pos += 1;
                            break;
                        }
                        Some(Token {
                            kind: TokenKind::ObjectName(_),
                            ..
                        }) => *pos += 1,
                        Some(t) => {
                            values.push(parse_value(t)?);
                            *pos += 1;
                        }
                    }
                }
            }
            Some(t) => {
                values.push(parse_value(t)?);
                *pos += 1;
            }
        }
        // Values of one list must agree with the declared type.
        let ok = match ty.as_str() {
            "bool" => values.iter().all(|v| matches!(v, Value::Bool(_))),
            "string" | "texture" => values.iter().all(|v| matches!(v, Value::Str(_))),
            "spectrum" => {
                values.iter().all(|v| matches!(v, Value::Num(_)))
                    || values.iter().all(|v| matches!(v, Value::Str(_)))
            }
            _ => values.iter().all(|v| matches!(v, Value::Num(_))),
        };
        if !ok {
            return Err(loc.err(format!(
                "parameter \"{name}\": values do not match its type \"{ty}\""
            )));
        }
        if ty == "integer" {
            if let Some(Value::Num(x)) = values
                .iter()
                .find(|v| matches!(v, Value::Num(x) if x.fract() != 0.0))
            {
                return Err(loc.err(format!("parameter \"{name}\": {x} is not an integer")));
            }
        }
        if list.params.iter().any(|p: &Param| p.name == name) {
            return Err(loc.err(format!("parameter \"{name}\" given twice")));
        }
        list.params.push(Param {
            ty,
            name: name.to_string(),
            values,
            loc,
            used: Cell::new(false),
        });
    }
    Ok(list)
}

impl ParamList {
    /// The parameter `name`, marking it used; error if it exists with another type.
    pub fn get(&self, name: &str, types: &[&str]) -> Result<Option<&Param>, PbrtError> {
        match self.params.iter().find(|p| p.name == name) {
            None => Ok(None),
            Some(p) => {
                if !types.contains(&p.ty.as_str()) {
                    return Err(p.loc.err(format!(
                        "parameter \"{name}\" has type \"{}\"; expected {}",
                        p.ty,
                        types
                            .iter()
                            .map(|t| format!("\"{t}\""))
                            .collect::<Vec<_>>()
                            .join(" or ")
                    )));
                }
                p.used.set(true);
                Ok(Some(p))
            }
        }
    }

    fn one_num(&self, name: &str, ty: &str) -> Result<Option<f64>, PbrtError> {
        match self.get(name, &[ty])? {
            None => Ok(None),
            Some(p) => {
                let v = p.nums()?;
                if v.len() != 1 {
                    return Err(p.loc.err(format!(
                        "parameter \"{name}\" needs exactly one value, got {}",
                        v.len()
                    )));
                }
                Ok(Some(v[0]))
            }
        }
    }

    pub fn float(&self, name: &str, default: f64) -> Result<f64, PbrtError> {
        Ok(self.one_num(name, "float")?.unwrap_or(default))
    }
    pub fn float_opt(&self, name: &str) -> Result<Option<f64>, PbrtError> {
        self.one_num(name, "float")
    }
    pub fn int(&self, name: &str, default: i64) -> Result<i64, PbrtError> {
        Ok(self
            .one_num(name, "integer")?
            .map(|v| v as i64)
            .unwrap_or(default))
    }
    pub fn bool(&self, name: &str, default: bool) -> Result<bool, PbrtError> {
        match self.get(name, &["bool"])? {
            None => Ok(default),
            Some(p) => match p.values.as_slice() {
                [Value::Bool(b)] => Ok(*b),
                _ => Err(p.loc.err(format!("parameter \"{name}\" needs one bool"))),
            },
        }
    }
    pub fn string(&self, name: &str) -> Result<Option<String>, PbrtError> {
        match self.get(name, &["string"])? {
            None => Ok(None),
            Some(p) => {
                let s = p.strings()?;
                if s.len() != 1 {
                    return Err(p
                        .loc
                        .err(format!("parameter \"{name}\" needs exactly one string")));
                }
                Ok(Some(s[0].clone()))
            }
        }
    }
    /// Numbers of type `ty`, grouped by `n` (e.g. point3 -> 3), or None if absent.
    pub fn tuples(
        &self,
        name: &str,
        ty: &[&str],
        n: usize,
    ) -> Result<Option<Vec<Vec<f64>>>, PbrtError> {
        match self.get(name, ty)? {
            None => Ok(None),
            Some(p) => {
                let v = p.nums()?;
                if v.len() % n != 0 {
                    return Err(p.loc.err(format!(
                        "parameter \"{name}\" has {} values, not a multiple of {n}",
                        v.len()
                    )));
                }
                Ok(Some(v.chunks(n).map(|c| c.to_vec()).collect()))
            }
        }
    }
    pub fn ints(&self, name: &str) -> Result<Option<(Vec<i64>, Loc)>, PbrtError> {
        match self.get(name, &["integer"])? {
            None => Ok(None),
            Some(p) => Ok(Some((
                p.nums()?.into_iter().map(|x| x as i64).collect(),
                p.loc.clone(),
            ))),
        }
    }

    /// Mark `name` as known-but-ignored: returns its location if present (for a note).
    pub fn ignore(&self, name: &str) -> Option<Loc> {
        self.params.iter().find(|p| p.name == name).map(|p| {
            p.used.set(true);
            p.loc.clone()
        })
    }

    /// Error for the first parameter no one asked for (pbrt-v4: "unused parameter").
    pub fn check_unused(&self, what: &str) -> Result<(), PbrtError> {
        if let Some(p) = self.params.iter().find(|p| !p.used.get()) {
            return Err(p.loc.err(format!(
                "{what}: unknown or unsupported parameter \"{} {}\"",
                p.ty, p.name
            )));
        }
        Ok(())
    }
}
