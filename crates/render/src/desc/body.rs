//! The properties and nested plugins the XML reader collects for one element, with the rule that a
//! name is bound once.

use super::{ChildDesc, Property};
use crate::error::{SceneError, SceneResult, SourceLoc};
use std::collections::HashMap;

/// The properties and nested plugins being collected for one element.
#[derive(Default)]
pub(super) struct Body {
    pub(super) props: Vec<Property>,
    pub(super) children: Vec<ChildDesc>,
    /// Where each name was first bound (properties and named children share one namespace).
    pub(super) names: HashMap<String, SourceLoc>,
}

impl Body {
    fn bind_name(&mut self, name: &str, loc: &SourceLoc) -> SceneResult<()> {
        if let Some(first) = self.names.get(name) {
            return Err(SceneError::at(
                loc,
                format!("'{name}' is specified more than once (first at {first})"),
            ));
        }
        self.names.insert(name.to_string(), loc.clone());
        Ok(())
    }

    pub(super) fn add_prop(&mut self, prop: Property) -> SceneResult<()> {
        self.bind_name(&prop.name, &prop.loc)?;
        self.props.push(prop);
        Ok(())
    }

    pub(super) fn add_child(&mut self, child: ChildDesc, loc: &SourceLoc) -> SceneResult<()> {
        if let Some(name) = &child.name {
            self.bind_name(name, loc)?;
        }
        self.children.push(child);
        Ok(())
    }
}
