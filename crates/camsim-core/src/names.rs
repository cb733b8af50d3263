//! One name table per family of named things (scene kinds, sensor and lens presets, demosaic and
//! white-balance methods, colour filter arrays, built-in 3D scenes, dataset outputs): the one
//! list that dispatch, `camsim presets`, the Python package, `--help` texts and error messages
//! ("unknown X 'y'; known: a, b, c") all read, so they cannot drift apart.
//!
//! One case rule for every lookup ([`key`]): surrounding space is ignored, letters compare
//! without case, and `_`, `-` and a space between words are the same (`Gray_World`,
//! `gray-world` and `gray world` name one method; `PIXEL4A` is `pixel4a`).

use crate::error::{CoreError, Result};

/// One entry of a [`NameTable`].
#[derive(Debug, Clone, Copy)]
pub struct Named<T: 'static> {
    /// The canonical name (what camsim prints and writes).
    pub name: &'static str,
    /// Other accepted names (ISETCam's, older spellings).
    pub aliases: &'static [&'static str],
    /// One line for `camsim presets` and `--help`.
    pub about: &'static str,
    /// What the name stands for.
    pub value: T,
}

/// The names of one family, in the order they are listed.
#[derive(Debug, Clone, Copy)]
pub struct NameTable<T: 'static> {
    /// The family in the singular, as error messages say it ("demosaic method").
    pub family: &'static str,
    /// The entries.
    pub entries: &'static [Named<T>],
}

/// The lookup key of a name: trimmed, lower case, `_` and spaces as `-`.
pub fn key(name: &str) -> String {
    name.trim()
        .chars()
        .map(|c| match c {
            '_' | ' ' => '-',
            c => c.to_ascii_lowercase(),
        })
        .collect()
}

impl<T: Copy + 'static> NameTable<T> {
    /// The canonical names, in table order.
    pub fn names(&self) -> Vec<&'static str> {
        self.entries.iter().map(|e| e.name).collect()
    }

    /// The canonical names joined by ", " (for messages and help texts).
    pub fn known(&self) -> String {
        self.names().join(", ")
    }

    /// The entry called `name` (canonical name or alias, under the case rule of [`key`]).
    pub fn entry(&self, name: &str) -> Option<&'static Named<T>> {
        let k = key(name);
        self.entries
            .iter()
            .find(|e| key(e.name) == k || e.aliases.iter().any(|a| key(a) == k))
    }

    /// The value called `name`, or an error that lists the known names.
    pub fn get(&self, name: &str) -> Result<T> {
        self.entry(name)
            .map(|e| e.value)
            .ok_or_else(|| self.unknown(name))
    }

    /// The canonical name of `name` (an alias becomes its canonical name).
    pub fn canonical(&self, name: &str) -> Result<&'static str> {
        self.entry(name)
            .map(|e| e.name)
            .ok_or_else(|| self.unknown(name))
    }

    /// The error for a name that is not in the table.
    pub fn unknown(&self, name: &str) -> CoreError {
        CoreError::UnknownName {
            family: self.family.to_string(),
            name: name.trim().to_string(),
            known: self.known(),
        }
    }

    /// `name  about` lines, names padded to one width (for `camsim presets` and `--help`).
    pub fn listing(&self) -> String {
        let w = self.entries.iter().map(|e| e.name.len()).max().unwrap_or(0);
        self.entries
            .iter()
            .map(|e| format!("  {:<w$}  {}\n", e.name, e.about))
            .collect()
    }
}

impl<T: Copy + PartialEq + 'static> NameTable<T> {
    /// The canonical name of `value`, if the table has it.
    pub fn name_of(&self, value: T) -> Option<&'static str> {
        self.entries
            .iter()
            .find(|e| e.value == value)
            .map(|e| e.name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: NameTable<u8> = NameTable {
        family: "test method",
        entries: &[
            Named {
                name: "gray-world",
                aliases: &["grey world"],
                about: "one",
                value: 1,
            },
            Named {
                name: "pixel4a",
                aliases: &[],
                about: "two",
                value: 2,
            },
        ],
    };

    #[test]
    fn one_case_rule_for_names_and_aliases() {
        for n in [
            "gray-world",
            "Gray_World",
            " GRAY WORLD ",
            "grey-world",
            "Grey_World",
        ] {
            assert_eq!(T.get(n).unwrap(), 1, "{n}");
        }
        assert_eq!(T.get("PIXEL4A").unwrap(), 2);
        assert_eq!(T.canonical("grey_world").unwrap(), "gray-world");
        assert_eq!(T.name_of(2), Some("pixel4a"));
    }

    #[test]
    fn unknown_names_list_the_known_ones() {
        let e = T.get("pixel5").unwrap_err().to_string();
        assert_eq!(
            e,
            "unknown test method 'pixel5'; known: gray-world, pixel4a"
        );
        assert!(T.listing().contains("  gray-world  one\n"));
    }
}
