//! The reader half of the pbrt-v4 parser (pbrt-v4 `parser.cpp`): scene text to directives. It
//! tokenizes each file, finds each directive and its location, reads `Include` and `Import`
//! files (relative to the including file, then to the main file's folder; cycles and nesting
//! deeper than 64 are errors), and records a failing directive's problem and resumes at the next
//! directive (one-pass reporting, stopping after [`MAX_ERRORS`]). What a directive means is the
//! [`ParserTarget`]'s business: the scene builder in `parser.rs` (graphics state, attribute
//! stack, scene objects), which reads each directive's arguments through [`Args`] and never sees
//! a token.

use crate::lexer::{tokenize, Token, TokenKind};
use crate::params::{parse_params, ParamList};
use crate::scene::Transform;
use crate::{Loc, PbrtError};
use std::path::{Path, PathBuf};

/// Problems reported before reading stops.
pub(crate) const MAX_ERRORS: usize = 100;

/// Deepest Include/Import nesting accepted.
const MAX_INCLUDE_DEPTH: usize = 64;

/// What the reader hands directives to (pbrt-v4 `ParserTarget`, with one entry point for all
/// directives rather than one method each: the target reads a directive's arguments, whose
/// types it knows, from `args`).
pub(crate) trait ParserTarget {
    /// Graphics state saved across an `Import`.
    type Saved;
    /// Directive `name` at `loc` (every directive but `Include` and `Import`).
    fn directive(&mut self, name: &str, args: &mut Args, loc: &Loc) -> Result<(), PbrtError>;
    /// A naming comment `#ObjectName NAME` (ISET3d's export convention).
    fn object_name(&mut self, name: String);
    /// `Import` at `loc` is about to read its file: refuse it where it is not allowed, or save
    /// the graphics state the imported file cannot change.
    fn begin_import(&mut self, loc: &Loc) -> Result<Self::Saved, PbrtError>;
    /// The imported file has been read: restore what [`ParserTarget::begin_import`] saved.
    fn end_import(&mut self, saved: Self::Saved);
}

/// A file name of a directive resolved as pbrt-v4 does: relative to the including file's
/// folder, else to the main file's folder (`main_dir`) if it exists there.
pub(crate) fn resolve_path(main_dir: &Path, including_file: &Path, name: &str) -> PathBuf {
    let p = Path::new(name);
    if p.is_absolute() {
        return p.to_path_buf();
    }
    let dir = including_file.parent().unwrap_or(Path::new(""));
    let a = dir.join(p);
    if a.exists() {
        return a;
    }
    let b = main_dir.join(p);
    if b.exists() {
        b
    } else {
        a
    }
}

fn canonical(p: &Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf())
}

/// Index of the first token at or after `from` that can start a directive: a bare word
/// beginning with an ASCII capital (pbrt directives; parameter values are numbers, strings,
/// brackets and lower-case `true`/`false`), or a naming comment.
fn next_directive(tokens: &[Token], from: usize) -> usize {
    (from..tokens.len())
        .find(|&i| match &tokens[i].kind {
            TokenKind::Word(w) => w.starts_with(|c: char| c.is_ascii_uppercase()),
            TokenKind::ObjectName(_) => true,
            _ => false,
        })
        .unwrap_or(tokens.len())
}

/// Reads a scene's files into a [`ParserTarget`].
pub(crate) struct Reader {
    main_dir: PathBuf,
    include_stack: Vec<PathBuf>,
    /// Problems found so far, in reading order.
    pub(crate) errors: Vec<PbrtError>,
    /// Too many problems: reading stopped.
    pub(crate) aborted: bool,
}

impl Reader {
    /// A reader of the scene whose main file is `path`.
    pub(crate) fn new(path: &Path) -> Reader {
        Reader {
            main_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
            include_stack: vec![canonical(path)],
            errors: Vec::new(),
            aborted: false,
        }
    }

    /// Record a problem and go on (one-pass reporting); `Err` once there are too many, or when
    /// reading was already abandoned (the error then only unwinds the include stack).
    fn record(&mut self, e: PbrtError) -> Result<(), PbrtError> {
        if self.aborted {
            return Err(e);
        }
        self.errors.push(e);
        if self.errors.len() >= MAX_ERRORS {
            self.aborted = true;
            return Err(self.errors[0].clone());
        }
        Ok(())
    }

    /// Read one file's text. A directive that fails is recorded and skipped: reading resumes at
    /// the next directive (the next bare word starting with a capital letter), so that every
    /// problem in the scene, across included files, is reported in one pass.
    pub(crate) fn read_text<T: ParserTarget>(
        &mut self,
        text: &str,
        file: &Path,
        target: &mut T,
    ) -> Result<(), PbrtError> {
        let tokens = match tokenize(text, file) {
            Ok(t) => t,
            Err(e) => return self.record(e),
        };
        let mut start = 0;
        let mut cur = 0;
        loop {
            match self.read_tokens(&tokens, start, file, target, &mut cur) {
                Ok(()) => return Ok(()),
                Err(e) => {
                    self.record(e)?;
                    start = next_directive(&tokens, cur + 1);
                }
            }
        }
    }

    /// The directives of `tokens` from `start`; `cur` is left at the token index of the
    /// directive being read (where to resume after a problem).
    fn read_tokens<T: ParserTarget>(
        &mut self,
        tokens: &[Token],
        start: usize,
        file: &Path,
        target: &mut T,
        cur: &mut usize,
    ) -> Result<(), PbrtError> {
        let mut pos = start;
        while pos < tokens.len() {
            *cur = pos;
            let tok = &tokens[pos];
            let loc = Loc {
                file: file.to_path_buf(),
                line: tok.line,
                column: tok.column,
            };
            let d = match &tok.kind {
                TokenKind::Word(w) => w.clone(),
                TokenKind::ObjectName(n) => {
                    target.object_name(n.clone());
                    pos += 1;
                    continue;
                }
                _ => return Err(loc.err(format!("expected a directive, found {}", tok.describe()))),
            };
            let mut args = Args {
                tokens,
                pos: pos + 1,
                file,
            };
            if d == "Include" || d == "Import" {
                self.include(&d, &mut args, &loc, target)?;
            } else {
                target.directive(&d, &mut args, &loc)?;
            }
            pos = args.pos;
        }
        Ok(())
    }

    /// `Include` or `Import` (`d`): read the named file into `target`.
    fn include<T: ParserTarget>(
        &mut self,
        d: &str,
        args: &mut Args,
        loc: &Loc,
        target: &mut T,
    ) -> Result<(), PbrtError> {
        let name = args.string(d)?;
        let path = resolve_path(&self.main_dir, args.file, &name);
        let canon = canonical(&path);
        if self.include_stack.contains(&canon) {
            return Err(loc.err(format!(
                "{d} \"{name}\": include cycle ({} is already being read)",
                path.display()
            )));
        }
        if self.include_stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(loc.err(format!(
                "{d} \"{name}\": includes nested deeper than {MAX_INCLUDE_DEPTH}"
            )));
        }
        let text = std::fs::read_to_string(&path).map_err(|e| {
            loc.err(format!(
                "{d} \"{name}\": cannot read {}: {e}",
                path.display()
            ))
        })?;
        let saved = if d == "Import" {
            Some(target.begin_import(loc)?)
        } else {
            None
        };
        self.include_stack.push(canon);
        self.read_text(&text, &path, target)?;
        if let Some(saved) = saved {
            target.end_import(saved);
        }
        self.include_stack.pop();
        Ok(())
    }
}

/// A directive's arguments: the tokens after its name, read in order by the [`ParserTarget`].
pub(crate) struct Args<'a> {
    tokens: &'a [Token],
    pos: usize,
    file: &'a Path,
}

impl<'a> Args<'a> {
    /// The file the directive is in.
    pub(crate) fn file(&self) -> &'a Path {
        self.file
    }

    /// A number.
    pub(crate) fn num(&mut self, directive: &str) -> Result<f64, PbrtError> {
        let file = self.file;
        match self.tokens.get(self.pos) {
            Some(t) => match &t.kind {
                TokenKind::Word(w) => match w.parse::<f64>() {
                    Ok(v) if v.is_finite() => {
                        self.pos += 1;
                        Ok(v)
                    }
                    _ => Err(PbrtError::at(
                        file,
                        t.line,
                        t.column,
                        format!("{directive}: expected a number, found \"{w}\""),
                    )),
                },
                _ => Err(PbrtError::at(
                    file,
                    t.line,
                    t.column,
                    format!("{directive}: expected a number, found {}", t.describe()),
                )),
            },
            None => Err(PbrtError::at(
                file,
                0,
                0,
                format!("{directive}: expected a number, found the end of the file"),
            )),
        }
    }

    /// `n` numbers.
    pub(crate) fn nums(&mut self, directive: &str, n: usize) -> Result<Vec<f64>, PbrtError> {
        (0..n).map(|_| self.num(directive)).collect()
    }

    /// 16 numbers, optionally in brackets: a matrix in pbrt-v4's column-major order.
    pub(crate) fn matrix16(&mut self, directive: &str, loc: &Loc) -> Result<Transform, PbrtError> {
        let bracket = matches!(
            self.tokens.get(self.pos).map(|t| &t.kind),
            Some(TokenKind::Open)
        );
        if bracket {
            self.pos += 1;
        }
        let v = self.nums(directive, 16)?;
        if bracket {
            match self.tokens.get(self.pos) {
                Some(t) if t.kind == TokenKind::Close => self.pos += 1,
                _ => return Err(loc.err(format!("{directive}: expected ']' after 16 numbers"))),
            }
        }
        // pbrt-v4: Transpose(SquareMatrix(tr)) -- the 16 numbers are the matrix in column-major order.
        let mut m = [[0.0; 4]; 4];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = v[j * 4 + i];
            }
        }
        Ok(Transform { m })
    }

    /// A quoted string.
    pub(crate) fn string(&mut self, directive: &str) -> Result<String, PbrtError> {
        let file = self.file;
        match self.tokens.get(self.pos) {
            Some(Token {
                kind: TokenKind::Str(s),
                ..
            }) => {
                self.pos += 1;
                Ok(s.clone())
            }
            Some(t) => Err(PbrtError::at(
                file,
                t.line,
                t.column,
                format!(
                    "{directive}: expected a quoted string, found {}",
                    t.describe()
                ),
            )),
            None => Err(PbrtError::at(
                file,
                0,
                0,
                format!("{directive}: expected a quoted string, found the end of the file"),
            )),
        }
    }

    /// A quoted string if one comes next.
    pub(crate) fn optional_string(&mut self) -> Option<String> {
        match self.tokens.get(self.pos) {
            Some(Token {
                kind: TokenKind::Str(s),
                ..
            }) => {
                self.pos += 1;
                Some(s.clone())
            }
            _ => None,
        }
    }

    /// A bare word (e.g. `ActiveTransform StartTime`) if one comes next.
    pub(crate) fn word(&mut self) -> Option<String> {
        match self.tokens.get(self.pos) {
            Some(Token {
                kind: TokenKind::Word(w),
                ..
            }) => {
                self.pos += 1;
                Some(w.clone())
            }
            _ => None,
        }
    }

    /// The parameter list.
    pub(crate) fn params(&mut self) -> Result<ParamList, PbrtError> {
        parse_params(self.tokens, &mut self.pos, self.file)
    }
}
