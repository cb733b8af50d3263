//! A small self-contained HTML report: headings, paragraphs, tables and PNG figures embedded as
//! base64 `data:` URIs (no external files, scripts or fonts).

use base64::Engine as _;

/// Escape text for HTML element content and attribute values.
pub fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

/// An HTML document under construction.
#[derive(Debug, Default, Clone)]
pub struct Html {
    title: String,
    body: String,
}

impl Html {
    /// A new document with a title.
    pub fn new(title: &str) -> Html {
        Html {
            title: title.to_string(),
            body: String::new(),
        }
    }

    /// A top-level section heading.
    pub fn h2(&mut self, text: &str, id: &str) {
        self.body
            .push_str(&format!("<h2 id=\"{}\">{}</h2>\n", esc(id), esc(text)));
    }

    /// A sub-heading.
    pub fn h3(&mut self, text: &str) {
        self.body.push_str(&format!("<h3>{}</h3>\n", esc(text)));
    }

    /// A paragraph of plain text.
    pub fn p(&mut self, text: &str) {
        self.body.push_str(&format!("<p>{}</p>\n", esc(text)));
    }

    /// Raw, already-escaped HTML.
    pub fn raw(&mut self, html: &str) {
        self.body.push_str(html);
        self.body.push('\n');
    }

    /// A table with a header row.
    pub fn table(&mut self, header: &[&str], rows: &[Vec<String>]) {
        let mut t = String::from("<table>\n<tr>");
        for h in header {
            t.push_str(&format!("<th>{}</th>", esc(h)));
        }
        t.push_str("</tr>\n");
        for r in rows {
            t.push_str("<tr>");
            for c in r {
                t.push_str(&format!("<td>{}</td>", esc(c)));
            }
            t.push_str("</tr>\n");
        }
        t.push_str("</table>\n");
        self.body.push_str(&t);
    }

    /// A PNG figure embedded as a data URI, with a caption.
    pub fn figure(&mut self, png: &[u8], caption: &str) {
        self.body.push_str(&format!(
            "<figure><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>\n",
            esc(caption),
            base64::engine::general_purpose::STANDARD.encode(png),
            esc(caption)
        ));
    }

    /// A pass/fail badge followed by text.
    pub fn check(&mut self, passed: bool, text: &str) {
        let (class, word) = if passed {
            ("pass", "PASS")
        } else {
            ("fail", "FAIL")
        };
        self.body.push_str(&format!(
            "<p><span class=\"{class}\">{word}</span> {}</p>\n",
            esc(text)
        ));
    }

    /// The complete document.
    pub fn finish(&self) -> String {
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title>\n<style>\n{}\n</style></head>\n<body>\n<h1>{}</h1>\n{}</body></html>\n",
            esc(&self.title),
            STYLE,
            esc(&self.title),
            self.body
        )
    }
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222;line-height:1.4}\
table{border-collapse:collapse;margin:0.8em 0;font-size:0.9em}td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}\
th{background:#eee}figure{display:inline-block;margin:0.5em;vertical-align:top}img{max-width:100%;border:1px solid #ddd}\
figcaption{font-size:0.85em;color:#555;max-width:640px}.pass{background:#2a2;color:#fff;padding:1px 6px;border-radius:3px}\
.fail{background:#c22;color:#fff;padding:1px 6px;border-radius:3px}code,pre{background:#f4f4f4;padding:2px 4px}pre{overflow-x:auto}";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup() {
        assert_eq!(
            esc("<a href=\"x\">&'"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
        let mut h = Html::new("T<1>");
        h.table(&["a"], &[vec!["<b>".into()]]);
        let s = h.finish();
        assert!(s.contains("<td>&lt;b&gt;</td>") && s.contains("<title>T&lt;1&gt;</title>"));
    }

    #[test]
    fn figures_are_standard_padded_base64() {
        // RFC 4648 section 10 vectors, and the two highest symbols ('+', '/') of the standard
        // alphabet (a data: URI needs it, not the URL-safe one).
        for (bytes, b64) in [
            (&b"fooba"[..], "Zm9vYmE="),
            (b"foobar", "Zm9vYmFy"),
            (&[0xfb, 0xff], "+/8="),
        ] {
            let mut h = Html::new("t");
            h.figure(bytes, "c");
            assert!(
                h.finish()
                    .contains(&format!("src=\"data:image/png;base64,{b64}\"")),
                "{b64}"
            );
        }
    }
}
