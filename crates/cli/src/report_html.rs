//! The `index.html` of a `focal compare` report: an interactive, offline comparison page.
//!
//! Everything the page needs lies beside it: the script and style are inlined, and each image's linear
//! float data is a small `data/NAME.js` file (half floats, base64) loaded with a `<script>` tag, since
//! browsers refuse `fetch` of `file://` URLs. Tonemapping (exposure, sRGB) happens in the page on a
//! canvas, so the exposure control is exact for HDR values. Opening `index.html#selftest` makes the page
//! test its own slider and write `SELFTEST PASS` (or the failure) into `#selftest`, for browser tests.

use anyhow::{Context, Result};
use base64::Engine;
use focal_render::film::Image;
use std::fmt::Write as _;
use std::path::Path;

const SCRIPT: &str = include_str!("../assets/report.js");
const STYLE: &str = include_str!("../assets/report.css");

/// One image the page can show in its viewer.
pub struct ViewerImage<'a> {
    /// Identifier (file-name safe).
    pub key: String,
    /// Shown name.
    pub label: String,
    /// The tonemapped PNG beside the page (relative path), linked for download.
    pub png: String,
    /// Linear RGB.
    pub image: &'a Image,
}

/// A picture shown as is (plots, error images, guide visualisations).
pub struct Figure {
    /// Relative path.
    pub src: String,
    /// Caption.
    pub caption: String,
}

/// Everything on the page.
pub struct ReportPage<'a> {
    /// Page title.
    pub title: String,
    /// One paragraph of what was compared and how (HTML-escaped here).
    pub summary: Vec<String>,
    /// Viewer images; the first is the reference.
    pub images: Vec<ViewerImage<'a>>,
    /// Table header cells.
    pub table_header: Vec<String>,
    /// Table rows.
    pub table_rows: Vec<Vec<String>>,
    /// Sections of figures: (heading, figures).
    pub sections: Vec<(String, Vec<Figure>)>,
    /// Default exposure (stops).
    pub exposure: f32,
}

/// Escapes text for HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Half-float little-endian RGB of an image, base64.
fn encode_f16(image: &Image) -> String {
    let mut bytes = Vec::with_capacity(image.rgb.len() * 6);
    for p in &image.rgb {
        for &v in p {
            let v = if v.is_finite() {
                v.clamp(0.0, 65000.0)
            } else {
                0.0
            };
            bytes.extend_from_slice(&half::f16::from_f32(v).to_le_bytes());
        }
    }
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// Writes `dir/index.html` and `dir/data/*.js`.
pub fn write_report(dir: &Path, page: &ReportPage) -> Result<()> {
    let data = dir.join("data");
    std::fs::create_dir_all(&data).with_context(|| format!("creating {}", data.display()))?;
    let mut html = String::new();
    let _ = write!(
        html,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>{}</title>\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <link rel=\"icon\" href=\"data:,\">\n<style>\n{STYLE}</style></head>\n<body>\n<h1>{}</h1>\n",
        esc(&page.title),
        esc(&page.title)
    );
    for p in &page.summary {
        let _ = writeln!(html, "<p>{}</p>", esc(p));
    }
    html += "<section id=\"viewer-section\"><h2>Images</h2>\n<div class=\"controls\">\n\
        <label>left <select id=\"sel-a\"></select></label>\n\
        <label>right <select id=\"sel-b\"></select></label>\n\
        <button id=\"flip\" title=\"swap left and right (key f)\">flip ⇄</button>\n";
    let _ = write!(
        html,
        "<label>exposure <input id=\"exposure\" type=\"range\" min=\"-10\" max=\"10\" step=\"0.1\" \
         value=\"{}\"> <span id=\"exposure-value\"></span> stops</label>\n\
         <label>split <input id=\"split\" type=\"range\" min=\"0\" max=\"1000\" step=\"1\" value=\"500\">\
         </label>\n<label>zoom <select id=\"zoom\"><option>2</option><option selected>4</option>\
         <option>8</option><option>16</option></select>×</label>\n</div>\n",
        page.exposure
    );
    html += "<p class=\"hint\">Drag on the image to move the split; click to choose the zoomed crops; \
        key f flips left and right.</p>\n<div class=\"view-wrap\"><canvas id=\"view\"></canvas></div>\n\
        <h3>Zoomed crops</h3><div id=\"crops\"></div>\n<p class=\"downloads\">";
    for im in &page.images {
        let _ = write!(
            html,
            "<a href=\"{}\">{}.png</a> ",
            esc(&im.png),
            esc(&im.label)
        );
    }
    html += "</p></section>\n<section><h2>Metrics</h2>\n<table id=\"metrics\"><thead><tr>";
    for h in &page.table_header {
        let _ = write!(html, "<th>{}</th>", esc(h));
    }
    html += "</tr></thead><tbody>\n";
    for row in &page.table_rows {
        html += "<tr>";
        for c in row {
            let _ = write!(html, "<td>{}</td>", esc(c));
        }
        html += "</tr>\n";
    }
    html += "</tbody></table>\n<p class=\"downloads\"><a href=\"metrics.csv\">metrics.csv</a> \
        <a href=\"metrics.json\">metrics.json</a> <a href=\"convergence.csv\">convergence.csv</a></p>\
        </section>\n";
    for (heading, figs) in &page.sections {
        if figs.is_empty() {
            continue;
        }
        let _ = writeln!(
            html,
            "<section><h2>{}</h2><div class=\"figures\">",
            esc(heading)
        );
        for f in figs {
            let _ = writeln!(
                html,
                "<figure><a href=\"{0}\"><img src=\"{0}\" alt=\"{1}\"></a><figcaption>{1}</figcaption></figure>",
                esc(&f.src),
                esc(&f.caption)
            );
        }
        html += "</div></section>\n";
    }
    html += "<pre id=\"selftest\"></pre>\n";
    let mut manifest = Vec::new();
    for im in &page.images {
        let file = format!("data/{}.js", im.key);
        let js = format!(
            "(window.FOCAL_DATA = window.FOCAL_DATA || {{}})[{}] = {{w: {}, h: {}, f16: \"{}\"}};\n",
            serde_json::to_string(&im.key)?,
            im.image.width,
            im.image.height,
            encode_f16(im.image)
        );
        std::fs::write(dir.join(&file), js).with_context(|| format!("writing {file}"))?;
        let _ = writeln!(html, "<script src=\"{}\"></script>", esc(&file));
        manifest.push(serde_json::json!({"key": im.key, "label": im.label}));
    }
    let _ = write!(
        html,
        "<script>\nconst FOCAL_IMAGES = {};\n{SCRIPT}</script>\n</body></html>\n",
        serde_json::to_string(&manifest)?
    );
    let path = dir.join("index.html");
    std::fs::write(&path, html).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
