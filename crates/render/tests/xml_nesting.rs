//! Deeply nested scene XML: the reader's and the builder's recursion is bounded by
//! `MAX_NESTING_DEPTH`, so a pathological file is an error at its line, never a stack overflow (issue 42:
//! 5,000 nested `<bsdf type="twosided">` aborted the process).

use focal_render::desc::xml::{parse_scene_str, MAX_NESTING_DEPTH};
use focal_render::scene::{build_scene, BuildOptions, Strictness};
use proptest::prelude::*;
use std::path::Path;

/// A scene whose one shape holds `depth` nested plugin elements of the given kind, one per line,
/// after the 3 header lines: the element at depth d (1 = the shape's child) is on line 3 + d.
fn nested_scene(depth: usize, open: &str, close: &str) -> String {
    let mut s = String::from(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n<shape type=\"sphere\">\n",
    );
    for _ in 0..depth {
        s += open;
        s += "\n";
    }
    s += "<bsdf type=\"diffuse\"/>\n";
    for _ in 0..depth {
        s += close;
    }
    s += "</shape>\n</scene>\n";
    s
}

const KINDS: [(&str, &str); 4] = [
    ("<bsdf type=\"twosided\">", "</bsdf>"),
    ("<bsdf type=\"blendbsdf\">", "</bsdf>"),
    (
        "<texture type=\"checkerboard\" name=\"color0\">",
        "</texture>",
    ),
    ("<emitter type=\"area\">", "</emitter>"),
];

#[test]
fn five_thousand_nested_twosided_bsdfs_are_an_error_at_the_line_past_the_limit() {
    let text = nested_scene(5000, KINDS[0].0, KINDS[0].1);
    let err = parse_scene_str(&text, Path::new("deep.xml"), &[]).unwrap_err();
    let msg = err.to_string();
    // The shape is plugin 1; its MAX_NESTING_DEPTH-th nested child (line 3 + that) is one too many.
    let line = 3 + MAX_NESTING_DEPTH;
    assert!(msg.contains(&format!("deep.xml:{line}:")), "{msg}");
    assert!(msg.contains("nested more than"), "{msg}");
}

#[test]
fn nesting_up_to_the_limit_is_read() {
    // The shape and its nested children fill the limit exactly.
    let text = nested_scene(MAX_NESTING_DEPTH - 2, KINDS[0].0, KINDS[0].1);
    parse_scene_str(&text, Path::new("ok.xml"), &[]).expect("within the limit");
}

/// Regression (issue 42): a `twosided` holds its one nested BSDF as both sides, and its lobe queries
/// walked both, so nested `twosided`s took time doubling with every level (30 levels: 9 s).
#[test]
fn twosided_nested_up_to_the_limit_builds() {
    let text = nested_scene(MAX_NESTING_DEPTH - 2, KINDS[0].0, KINDS[0].1);
    let desc = parse_scene_str(&text, Path::new("deep.xml"), &[]).expect("within the limit");
    let opts = BuildOptions {
        strictness: Strictness::Lenient,
        ..Default::default()
    };
    build_scene(&desc, &opts).expect("nested twosided builds");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Any depth of any kind of nesting is read, or refused with the file and line; building what was
    /// read never overflows either (the builder recurses over the same tree).
    #[test]
    fn any_nesting_depth_is_read_or_refused_at_a_line(
        depth in prop_oneof![0usize..80, 80usize..20_000],
        kind in 0usize..KINDS.len(),
    ) {
        let (open, close) = KINDS[kind];
        let text = nested_scene(depth, open, close);
        match parse_scene_str(&text, Path::new("fuzz.xml"), &[]) {
            Ok(desc) => {
                prop_assert!(depth + 2 <= MAX_NESTING_DEPTH, "depth {depth} was accepted");
                let opts = BuildOptions { strictness: Strictness::Lenient, ..Default::default() };
                if let Err(e) = build_scene(&desc, &opts) {
                    prop_assert!(e.to_string().contains("fuzz.xml"), "{e}");
                }
            }
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(msg.contains("fuzz.xml:"), "{msg}");
                prop_assert!(depth + 2 > MAX_NESTING_DEPTH, "depth {depth} refused: {msg}");
            }
        }
    }
}
