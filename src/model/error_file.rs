//! Error files. (Being written on branch model-files; this stub keeps the tree building.)
use crate::model::{ErrorModel, Machine};
use std::path::Path;

pub fn parse(_text: &str, path: &str, _machine: &Machine) -> crate::Result<ErrorModel> {
    Err(crate::Error::Usage(format!(
        "{path}: error files are not readable yet"
    )))
}

pub fn load(path: &Path, machine: &Machine) -> crate::Result<ErrorModel> {
    let text = std::fs::read_to_string(path).map_err(|e| crate::Error::io(path, e))?;
    parse(&text, &path.display().to_string(), machine)
}
