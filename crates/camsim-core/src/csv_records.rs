//! CSV records (read with the `csv` crate) together with the line of the file each starts on, so
//! that every reader of a CSV file (spectra here, measurement files in camsim-io) can name the
//! line of a bad value.
//!
//! The line is counted from the record's byte offset, not taken from `csv::Position::line`: that
//! reports the line of a blank line for the first record after it (rust-csv issue #208).

/// A record and the 1-based line of the input it starts on.
pub type Record = (usize, csv::StringRecord);

/// Every record of `input` with its line: RFC 4180 quoting (`"a,b"` is one field, `""` inside
/// quotes one quote), fields trimmed, blank lines skipped, and, when `comments` is set, `#`
/// comment lines (indented ones too) skipped. Records may have different lengths (the caller
/// names a ragged row). An error comes with the line it was found on.
pub fn records(input: &[u8], comments: bool) -> Result<Vec<Record>, (usize, csv::Error)> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .comment(comments.then_some(b'#'))
        .from_reader(input);
    let mut lines = LineCounter::default();
    let mut out = Vec::new();
    for record in reader.records() {
        let record = match record {
            Ok(r) => r,
            Err(e) => return Err((lines.line_at(input, e.position(), comments), e)),
        };
        let line = lines.line_at(input, record.position(), comments);
        let blank = record.len() == 1 && record[0].is_empty();
        if blank || (comments && record[0].starts_with('#')) {
            continue;
        }
        out.push((line, record));
    }
    Ok(out)
}

/// What went wrong in a [`csv::Error`], without its position (the caller's message names the
/// line).
pub fn error_message(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::Utf8 { err, .. } => format!("not UTF-8 text ({err})"),
        _ => format!("not readable as CSV ({e})"),
    }
}

/// Turns byte offsets (increasing from call to call) into 1-based lines, counting each byte once.
#[derive(Default)]
struct LineCounter {
    offset: usize,
    newlines: usize,
}

impl LineCounter {
    /// The line of the record at `pos`: past the line ends, blank lines and (with `comments`)
    /// `#` lines the parser may have consumed before the record itself.
    fn line_at(&mut self, input: &[u8], pos: Option<&csv::Position>, comments: bool) -> usize {
        let Some(pos) = pos else {
            return self.newlines + 1;
        };
        let mut i = usize::try_from(pos.byte())
            .unwrap_or(usize::MAX)
            .min(input.len());
        loop {
            while i < input.len() && matches!(input[i], b'\n' | b'\r') {
                i += 1;
            }
            if comments && input.get(i) == Some(&b'#') {
                while i < input.len() && input[i] != b'\n' {
                    i += 1;
                }
                continue;
            }
            break;
        }
        if i > self.offset {
            self.newlines += input[self.offset..i]
                .iter()
                .filter(|b| **b == b'\n')
                .count();
            self.offset = i;
        }
        self.newlines + 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines_and_fields(text: &str, comments: bool) -> Vec<(usize, Vec<String>)> {
        records(text.as_bytes(), comments)
            .unwrap()
            .into_iter()
            .map(|(l, r)| (l, r.iter().map(String::from).collect()))
            .collect()
    }

    #[test]
    fn lines_count_blank_and_comment_lines() {
        let text = "a,b\n\n1,2\n\n\n# c, \"d\n3,4\r\n\r\n  # e\n\"5\n6\",\" 7 \"\n8\n";
        let got = lines_and_fields(text, true);
        let want: Vec<(usize, Vec<String>)> = vec![
            (1, vec!["a".into(), "b".into()]),
            (3, vec!["1".into(), "2".into()]),
            (7, vec!["3".into(), "4".into()]),
            (10, vec!["5\n6".into(), "7".into()]),
            (12, vec!["8".into()]),
        ];
        assert_eq!(got, want);
        // Without comments, '#' lines are records.
        let got = lines_and_fields("#x\n\n1\n", false);
        assert_eq!(
            got,
            vec![(1, vec!["#x".to_string()]), (3, vec!["1".to_string()])]
        );
    }

    #[test]
    fn errors_come_with_their_line() {
        let (line, e) = records(b"a\n\n1\n\n\xff,2\n", false).unwrap_err();
        assert_eq!(line, 5);
        assert!(matches!(e.kind(), csv::ErrorKind::Utf8 { .. }), "{e}");
    }
}
