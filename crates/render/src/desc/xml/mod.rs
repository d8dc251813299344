//! Mitsuba XML reader (both the 0.6 and the 3.x dialects) producing a [`super::SceneDesc`].
//!
//! The reader follows Mitsuba 3's `xml.cpp`: `$variables` are substituted in every attribute value
//! (`<default>` declares them, `-D` overrides them, and an unused `-D` is an error in 3.x files),
//! `<transform>` children compose in document order, `<include>` inlines another file's `<scene>`
//! children, `<ref>`/`<alias>` share objects by id. Property and `name=` attributes are normalised to
//! snake_case (so 0.6 files read like 3.x ones), `<camera>` is a sensor and files older than 2.0 get
//! Mitsuba 3's in-memory upgrade (diffuse `diffuse_reflectance` → `reflectance`, `uoffset`/`uscale`
//! → a `to_uv` transform). Relative `filename`s that do not exist beside the XML that wrote them are
//! looked up, as Mitsuba's file resolver does, beside the main scene file and in `<path>` folders.

mod values;

pub use values::look_at;

use super::body::Body;
use super::legacy::upgrade_legacy;
use super::{ChildDesc, ObjectClass, ObjectDesc, SceneDesc};
use crate::error::{SceneError, SceneResult, SourceLoc};
use roxmltree::{Document, Node, NodeType, ParsingOptions};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Deepest chain of nested `<include>`s accepted (Mitsuba 3's limit is 15, too).
const MAX_INCLUDE_DEPTH: usize = 15;

/// Deepest nesting of plugin elements accepted (a `<bsdf>` in a `<bsdf>` in a `<shape>` is 3 deep).
/// Real scenes nest a handful of levels; the limit keeps the reader's and the scene builder's recursion
/// far from the stack's end, so a pathological file is an error at its line rather than a crash.
pub const MAX_NESTING_DEPTH: usize = 64;

/// Parses a Mitsuba scene file into the neutral description. `params` are `-D name=value` overrides.
pub fn parse_scene_file(path: &Path, params: &[(String, String)]) -> SceneResult<SceneDesc> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| SceneError::in_file(path, format!("cannot read scene file: {e}")))?;
    parse_scene_str(&text, path, params)
}

/// Same, from a string (for tests); `path` is used for locations and relative includes.
pub fn parse_scene_str(
    text: &str,
    path: &Path,
    params: &[(String, String)],
) -> SceneResult<SceneDesc> {
    let file = Arc::new(path.to_path_buf());
    let doc = parse_xml(text, &file)?;
    let root = doc.root_element();
    let mut reader = Reader::new(path, params);
    let probe = FileCtx::new(&doc, file.clone(), false);
    let loc = probe.loc(root);
    if root.tag_name().name() != "scene" {
        return Err(SceneError::at(
            &loc,
            format!(
                "the root element must be <scene>, found <{}>",
                root.tag_name().name()
            ),
        ));
    }
    reader.check_attributes(root, &probe, &["version"])?;
    let version = match reader.attr(root, "version", &probe)? {
        Some(v) => parse_version(&v).ok_or_else(|| {
            SceneError::at(&loc, format!("could not parse the version number '{v}'"))
        })?,
        None => {
            return Err(SceneError::at(
                &loc,
                "missing version attribute in <scene> (e.g. version=\"3.0.0\")",
            ))
        }
    };
    let ctx = FileCtx::new(&doc, file, version < (2, 0, 0));
    let mut body = Body::default();
    reader.include_stack.push(canonical(path));
    reader.parse_children(root, &ctx, &mut body, true)?;

    if version.0 >= 1 {
        let mut unused: Vec<&str> = reader
            .vars
            .iter()
            .filter(|(_, v)| v.from_command_line && !v.used)
            .map(|(k, _)| k.as_str())
            .collect();
        if !unused.is_empty() {
            unused.sort_unstable();
            return Err(SceneError::in_file(
                path,
                format!(
                    "unused parameter(s) given with -D: {} (the scene never references them as $name)",
                    unused.join(", ")
                ),
            ));
        }
    }

    let scene = ObjectDesc {
        class: ObjectClass::Scene,
        plugin: String::new(),
        id: None,
        props: body.props,
        children: body.children,
        loc,
    };
    Ok(SceneDesc {
        root: Arc::new(scene),
        version,
        path: path.to_path_buf(),
    })
}

/// Normalises a Mitsuba 0.6 camelCase name to Mitsuba 3's snake_case: `_` goes between a lowercase
/// letter or digit and an uppercase letter, and between an uppercase letter and an uppercase+lowercase
/// pair; then everything is lowercased (`toWorld` → `to_world`, `intIOR` → `int_ior`,
/// `extIORScale` → `ext_ior_scale`). snake_case names are unchanged.
pub fn to_snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    for (i, &c) in chars.iter().enumerate() {
        if c.is_uppercase() && i > 0 {
            let prev = chars[i - 1];
            let next_is_lower = chars.get(i + 1).is_some_and(|n| n.is_lowercase());
            if prev.is_lowercase()
                || prev.is_ascii_digit()
                || (prev.is_uppercase() && next_is_lower)
            {
                out.push('_');
            }
        }
        out.extend(c.to_lowercase());
    }
    out
}

/// Parses XML text, turning roxmltree's error into a located [`SceneError`].
fn parse_xml<'t>(text: &'t str, file: &Arc<PathBuf>) -> SceneResult<Document<'t>> {
    let opts = ParsingOptions {
        allow_dtd: true,
        ..ParsingOptions::default()
    };
    Document::parse_with_options(text, opts).map_err(|e| {
        let pos = e.pos();
        SceneError::at(
            &SourceLoc {
                file: file.clone(),
                line: pos.row,
                col: pos.col,
            },
            format!("malformed XML: {e}"),
        )
    })
}

/// `"3.0.0"` → `(3, 0, 0)`; one to three numeric components, missing ones are 0.
fn parse_version(text: &str) -> Option<(u32, u32, u32)> {
    let parts: Vec<&str> = text.trim().split('.').collect();
    if parts.is_empty() || parts.len() > 3 {
        return None;
    }
    let mut v = [0u32; 3];
    for (slot, part) in v.iter_mut().zip(&parts) {
        *slot = part.trim().parse().ok()?;
    }
    Some((v[0], v[1], v[2]))
}

/// A path made absolute without requiring it to exist (for include-cycle detection and resolved files).
pub(super) fn canonical(path: &Path) -> PathBuf {
    path.canonicalize()
        .or_else(|_| std::path::absolute(path))
        .unwrap_or_else(|_| path.to_path_buf())
}

/// The plugin class of a tag that always denotes a plugin.
fn plugin_class(tag: &str) -> Option<ObjectClass> {
    Some(match tag {
        "shape" => ObjectClass::Shape,
        "bsdf" => ObjectClass::Bsdf,
        "emitter" => ObjectClass::Emitter,
        "sensor" | "camera" => ObjectClass::Sensor,
        "film" => ObjectClass::Film,
        "rfilter" => ObjectClass::Rfilter,
        "sampler" => ObjectClass::Sampler,
        "integrator" => ObjectClass::Integrator,
        "texture" => ObjectClass::Texture,
        "medium" => ObjectClass::Medium,
        "phase" => ObjectClass::Phase,
        _ => return None,
    })
}

/// One XML file being read: its document, path and dialect.
struct FileCtx<'a, 'input> {
    doc: &'a Document<'input>,
    file: Arc<PathBuf>,
    /// Directory of the file, for relative paths.
    dir: PathBuf,
    /// Version older than 2.0: apply Mitsuba 3's in-memory upgrade rules.
    legacy: bool,
}

impl<'a, 'input> FileCtx<'a, 'input> {
    fn new(doc: &'a Document<'input>, file: Arc<PathBuf>, legacy: bool) -> Self {
        let dir = file.parent().map(Path::to_path_buf).unwrap_or_default();
        FileCtx {
            doc,
            file,
            dir,
            legacy,
        }
    }

    fn loc(&self, node: Node) -> SourceLoc {
        let pos = self.doc.text_pos_at(node.range().start);
        SourceLoc {
            file: self.file.clone(),
            line: pos.row,
            col: pos.col,
        }
    }

    fn error(&self, node: Node, message: impl Into<String>) -> SceneError {
        SceneError::at(&self.loc(node), message)
    }
}

/// A `$name` variable: declared by `<default>` or given with `-D`.
struct Variable {
    value: String,
    from_command_line: bool,
    used: bool,
}

/// State shared across the main file and its includes.
struct Reader {
    /// Directory of the main scene file (Mitsuba's file resolver starts there).
    main_dir: PathBuf,
    vars: HashMap<String, Variable>,
    ids: HashMap<String, (Arc<ObjectDesc>, SourceLoc)>,
    /// `<path>` folders, most recent first.
    search_paths: Vec<PathBuf>,
    /// Canonical paths of the files being read, outermost first.
    include_stack: Vec<PathBuf>,
    /// Plugin elements open around the one being read (see [`MAX_NESTING_DEPTH`]).
    depth: usize,
}

impl Reader {
    fn new(path: &Path, params: &[(String, String)]) -> Self {
        let vars = params
            .iter()
            .map(|(k, v)| {
                (
                    k.clone(),
                    Variable {
                        value: v.clone(),
                        from_command_line: true,
                        used: false,
                    },
                )
            })
            .collect();
        Reader {
            main_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
            vars,
            ids: HashMap::new(),
            search_paths: Vec::new(),
            include_stack: Vec::new(),
            depth: 0,
        }
    }

    // ----- attributes -------------------------------------------------------------------------

    /// Replaces every `$name` in `text`. A name is an identifier run; when the whole run is not
    /// declared, its longest declared prefix is used (Mitsuba substitutes `$name` textually, so
    /// `$name_x` with only `name` declared means the value of `name` followed by `_x`).
    fn substitute(&mut self, text: &str, ctx: &FileCtx, node: Node) -> SceneResult<String> {
        if !text.contains('$') {
            return Ok(text.to_string());
        }
        let mut out = String::with_capacity(text.len());
        let mut rest = text;
        while let Some(pos) = rest.find('$') {
            out.push_str(&rest[..pos]);
            let after = &rest[pos + 1..];
            let run = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let ident = &after[..run];
            let mut consumed = None;
            for n in (1..=ident.len()).rev() {
                if let Some(var) = self.vars.get_mut(&ident[..n]) {
                    var.used = true;
                    out.push_str(&var.value);
                    consumed = Some(n);
                    break;
                }
            }
            match consumed {
                Some(n) => rest = &after[n..],
                None if ident.is_empty() => {
                    return Err(ctx.error(
                        node,
                        format!("stray '$' in attribute value \"{text}\" (expected $name)"),
                    ))
                }
                None => {
                    return Err(ctx.error(
                        node,
                        format!(
                        "undefined variable '${ident}' (declare it with <default name=\"{ident}\" \
                             value=\"...\"/> or pass -D {ident}=...)"
                    ),
                    ))
                }
            }
        }
        out.push_str(rest);
        Ok(out)
    }

    /// An attribute value with `$variables` substituted.
    fn attr(&mut self, node: Node, name: &str, ctx: &FileCtx) -> SceneResult<Option<String>> {
        match node.attribute(name) {
            Some(v) => self.substitute(v, ctx, node).map(Some),
            None => Ok(None),
        }
    }

    /// A required attribute value with `$variables` substituted.
    fn required(&mut self, node: Node, name: &str, ctx: &FileCtx) -> SceneResult<String> {
        self.attr(node, name, ctx)?.ok_or_else(|| {
            ctx.error(
                node,
                format!("missing attribute '{name}' in <{}>", node.tag_name().name()),
            )
        })
    }

    /// Rejects attributes other than `allowed` (typos would otherwise be silently ignored).
    fn check_attributes(&self, node: Node, ctx: &FileCtx, allowed: &[&str]) -> SceneResult<()> {
        for a in node.attributes() {
            if !allowed.contains(&a.name()) {
                return Err(ctx.error(
                    node,
                    format!(
                        "unexpected attribute '{}' in <{}> (allowed: {})",
                        a.name(),
                        node.tag_name().name(),
                        allowed.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    // ----- elements ---------------------------------------------------------------------------

    /// Reads the children of `node` into `body`.
    fn parse_children(
        &mut self,
        node: Node,
        ctx: &FileCtx,
        body: &mut Body,
        at_root: bool,
    ) -> SceneResult<()> {
        for child in node.children() {
            match child.node_type() {
                NodeType::Element => self.parse_element(child, ctx, body, at_root)?,
                NodeType::Text => check_no_text(child, ctx)?,
                _ => {}
            }
        }
        Ok(())
    }

    /// Reads one child element of a plugin (or of the scene, when `at_root`).
    fn parse_element(
        &mut self,
        node: Node,
        ctx: &FileCtx,
        body: &mut Body,
        at_root: bool,
    ) -> SceneResult<()> {
        let tag = node.tag_name().name();
        match tag {
            "float" | "integer" | "boolean" | "string" | "rgb" | "color" | "srgb" | "blackbody"
            | "point" | "vector" | "transform" => {
                let prop = self.parse_property(node, ctx)?;
                body.add_prop(prop)
            }
            "spectrum" if !node.has_attribute("type") => {
                let prop = self.parse_property(node, ctx)?;
                body.add_prop(prop)
            }
            "ref" => self.parse_ref(node, ctx, body),
            "include" => self.parse_include(node, ctx, body, at_root),
            "default" => self.parse_default(node, ctx),
            "alias" => self.parse_alias(node, ctx),
            "path" => self.parse_search_path(node, ctx, at_root),
            "scene" => Err(ctx.error(node, "<scene> can only be the root element")),
            "null" => Err(ctx.error(node, "<null> is not supported (remove the element)")),
            "translate" | "rotate" | "scale" | "matrix" | "lookat" | "lookAt" => {
                Err(ctx.error(node, format!("<{tag}> can only occur inside a <transform>")))
            }
            _ => {
                let class = match plugin_class(tag) {
                    Some(c) => c,
                    None if node.has_attribute("type") => ObjectClass::Other(tag.to_string()),
                    None => return Err(ctx.error(node, format!("unexpected element <{tag}>"))),
                };
                let loc = ctx.loc(node);
                let child = self.parse_object(node, class, ctx)?;
                body.add_child(child, &loc)
            }
        }
    }

    /// A plugin element with its nested properties and plugins.
    fn parse_object(
        &mut self,
        node: Node,
        class: ObjectClass,
        ctx: &FileCtx,
    ) -> SceneResult<ChildDesc> {
        self.check_attributes(node, ctx, &["type", "id", "name"])?;
        let loc = ctx.loc(node);
        let tag = node.tag_name().name();
        let plugin = self.required(node, "type", ctx)?;
        if plugin.trim().is_empty() {
            return Err(ctx.error(node, format!("empty 'type' in <{tag}>")));
        }
        let id = self.attr(node, "id", ctx)?;
        if id.as_deref().is_some_and(|i| i.trim().is_empty()) {
            return Err(ctx.error(node, format!("empty 'id' in <{tag}>")));
        }
        let name = self.attr(node, "name", ctx)?.map(|n| to_snake_case(&n));
        if self.depth >= MAX_NESTING_DEPTH {
            return Err(ctx.error(
                node,
                format!("<{tag}> is nested more than {MAX_NESTING_DEPTH} plugins deep"),
            ));
        }
        let mut body = Body::default();
        self.depth += 1;
        let children = self.parse_children(node, ctx, &mut body, false);
        self.depth -= 1;
        children?;
        if ctx.legacy {
            upgrade_legacy(&class, &plugin, &loc, &mut body)?;
        }
        let object = Arc::new(ObjectDesc {
            class,
            plugin,
            id: id.clone(),
            props: body.props,
            children: body.children,
            loc: loc.clone(),
        });
        if let Some(id) = id {
            self.register_id(id, object.clone(), &loc)?;
        }
        Ok(ChildDesc { name, object })
    }

    fn register_id(
        &mut self,
        id: String,
        object: Arc<ObjectDesc>,
        loc: &SourceLoc,
    ) -> SceneResult<()> {
        if let Some((_, first)) = self.ids.get(&id) {
            return Err(SceneError::at(
                loc,
                format!("duplicate id '{id}' (first declared at {first})"),
            ));
        }
        self.ids.insert(id, (object, loc.clone()));
        Ok(())
    }

    /// `<ref id=".." [name=".."]/>`: the earlier object with that id, shared.
    fn parse_ref(&mut self, node: Node, ctx: &FileCtx, body: &mut Body) -> SceneResult<()> {
        self.check_attributes(node, ctx, &["id", "name"])?;
        let id = self.required(node, "id", ctx)?;
        let name = self.attr(node, "name", ctx)?.map(|n| to_snake_case(&n));
        let Some((object, _)) = self.ids.get(&id) else {
            return Err(ctx.error(
                node,
                format!("<ref> to unknown id '{id}' (objects must be declared before they are referenced)"),
            ));
        };
        let child = ChildDesc {
            name,
            object: object.clone(),
        };
        body.add_child(child, &ctx.loc(node))
    }

    /// `<alias id="a" as="b"/>`: makes `b` another id of object `a`.
    fn parse_alias(&mut self, node: Node, ctx: &FileCtx) -> SceneResult<()> {
        self.check_attributes(node, ctx, &["id", "as"])?;
        let id = self.required(node, "id", ctx)?;
        let alias = self.required(node, "as", ctx)?;
        let Some((object, _)) = self.ids.get(&id) else {
            return Err(ctx.error(node, format!("<alias> of unknown id '{id}'")));
        };
        let object = object.clone();
        self.register_id(alias, object, &ctx.loc(node))
    }

    /// `<default name value/>`: declares a variable unless `-D` or an earlier default already did.
    fn parse_default(&mut self, node: Node, ctx: &FileCtx) -> SceneResult<()> {
        self.check_attributes(node, ctx, &["name", "value"])?;
        let name = self.required(node, "name", ctx)?;
        let value = self.required(node, "value", ctx)?;
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(ctx.error(
                node,
                format!("invalid <default> name '{name}' (use letters, digits and '_')"),
            ));
        }
        self.vars.entry(name).or_insert(Variable {
            value,
            from_command_line: false,
            used: false,
        });
        Ok(())
    }

    /// `<path value=".."/>`: another folder to look for included and referenced files in.
    fn parse_search_path(&mut self, node: Node, ctx: &FileCtx, at_root: bool) -> SceneResult<()> {
        self.check_attributes(node, ctx, &["value"])?;
        if !at_root {
            return Err(ctx.error(node, "<path> can only be a child of <scene>"));
        }
        let value = self.required(node, "value", ctx)?;
        let dir = ctx.dir.join(&value);
        // A missing folder is harmless (nothing will be found there), and scenes copied out of their
        // original repository often point at one; Mitsuba would reject it, we keep going.
        self.search_paths.insert(0, canonical(&dir));
        Ok(())
    }

    /// Finds a relative file the way Mitsuba's file resolver does: beside the XML that names it, beside
    /// the main scene file, then in `<path>` folders. `None` if it exists nowhere.
    fn locate(&self, rel: &str, ctx: &FileCtx) -> Option<PathBuf> {
        let p = Path::new(rel);
        if p.is_absolute() {
            return p.exists().then(|| p.to_path_buf());
        }
        std::iter::once(&ctx.dir)
            .chain(std::iter::once(&self.main_dir))
            .chain(self.search_paths.iter())
            .map(|d| d.join(p))
            .find(|c| c.exists())
    }

    /// `<include filename=".."/>`: inlines the other file's `<scene>` children (or its single root
    /// element) into `body`.
    fn parse_include(
        &mut self,
        node: Node,
        ctx: &FileCtx,
        body: &mut Body,
        at_root: bool,
    ) -> SceneResult<()> {
        self.check_attributes(node, ctx, &["filename"])?;
        let rel = self.required(node, "filename", ctx)?;
        let Some(path) = self.locate(&rel, ctx) else {
            return Err(ctx.error(
                node,
                format!(
                    "included file '{rel}' not found (looked in {})",
                    ctx.dir.join(&rel).display()
                ),
            ));
        };
        let key = canonical(&path);
        if self.include_stack.contains(&key) {
            return Err(ctx.error(
                node,
                format!("include cycle: '{}' includes itself", path.display()),
            ));
        }
        if self.include_stack.len() > MAX_INCLUDE_DEPTH {
            return Err(ctx.error(
                node,
                format!("<include> nested more than {MAX_INCLUDE_DEPTH} levels deep"),
            ));
        }
        let text = std::fs::read_to_string(&path).map_err(|e| {
            ctx.error(
                node,
                format!("cannot read included file '{}': {e}", path.display()),
            )
        })?;
        let file = Arc::new(path);
        let doc = parse_xml(&text, &file)?;
        let root = doc.root_element();
        let probe = FileCtx::new(&doc, file.clone(), ctx.legacy);
        let is_scene = root.tag_name().name() == "scene";
        let mut legacy = ctx.legacy;
        if is_scene {
            self.check_attributes(root, &probe, &["version"])?;
            if let Some(v) = self.attr(root, "version", &probe)? {
                let version = parse_version(&v).ok_or_else(|| {
                    probe.error(root, format!("could not parse the version number '{v}'"))
                })?;
                legacy = version < (2, 0, 0);
            }
        }
        let inner = FileCtx::new(&doc, file, legacy);
        self.include_stack.push(key);
        let result = if is_scene {
            self.parse_children(root, &inner, body, at_root)
        } else {
            self.parse_element(root, &inner, body, at_root)
        };
        self.include_stack.pop();
        result
    }
}

/// Text between elements must be whitespace (Mitsuba rejects "unexpected content").
fn check_no_text(node: Node, ctx: &FileCtx) -> SceneResult<()> {
    let text = node.text().unwrap_or("").trim();
    if text.is_empty() {
        Ok(())
    } else {
        let shown: String = text.chars().take(40).collect();
        Err(ctx.error(node, format!("unexpected text \"{shown}\"")))
    }
}
