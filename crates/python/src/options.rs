//! Keyword options of `spherify.embed` and `spherify.improve`, read one by
//! one into the core's parameter types, through the core's table of each
//! method's options ([`spherify_sphere::method_options`]): the table says
//! which options exist, their kinds, limits and which other option they need;
//! this file only checks Python types (a count is an int, not a float or a
//! bool) and translates. An option the method does not list is a `MeshError`
//! that lists the ones it does, before anything is read.

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};
use spherify_sparse::weights::Weights;
use spherify_sphere::method_options::{MethodOption, OptionDefault, OptionKind, OptionValue};
use spherify_sphere::MethodName;

use crate::errors::mesh_error;

/// The options given for one method, consumed as the method reads them.
pub struct Options<'py> {
    method: MethodName,
    table: Vec<MethodOption>,
    given: Bound<'py, PyDict>,
}

impl<'py> Options<'py> {
    /// Copies `given` and refuses at once a name `method` does not list, and
    /// an option given without the value of another option it needs
    /// (`rho` without `weights="chord"`): taking it without a word would
    /// hide the caller's mistake.
    pub fn new(
        py: Python<'py>,
        method: MethodName,
        given: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Options<'py>> {
        let given = match given {
            Some(d) => d.copy()?,
            None => PyDict::new(py),
        };
        let options = Options { method, table: method.options(), given };
        options.refuse_unknown()?;
        options.refuse_unmet_requirements()?;
        Ok(options)
    }

    fn given_names(&self) -> PyResult<Vec<String>> {
        self.given.keys().iter().map(|k| k.str().map(|s| s.to_string())).collect()
    }

    fn refuse_unknown(&self) -> PyResult<()> {
        let unknown: Vec<String> = self
            .given_names()?
            .into_iter()
            .filter(|name| !self.table.iter().any(|o| o.name == name))
            .map(|name| format!("{name:?}"))
            .collect();
        if unknown.is_empty() {
            return Ok(());
        }
        let mut known: Vec<&str> = self.table.iter().map(|o| o.name).collect();
        known.sort_unstable();
        Err(mesh_error(format!(
            "method {:?} has no option {}; its options are: {}",
            self.method.as_str(),
            unknown.join(", "),
            known.join(", ")
        )))
    }

    /// The name given for `option`, or its default name; `None` when the
    /// value given is not a name (a pole pair, say).
    fn name_given(&self, option: &str) -> PyResult<Option<String>> {
        match self.given.get_item(option)?.filter(|v| !v.is_none()) {
            Some(value) => Ok(value.cast::<PyString>().ok().map(|s| s.to_string())),
            None => {
                Ok(self.table.iter().find(|o| o.name == option).and_then(|o| match &o.default {
                    OptionDefault::Value(OptionValue::Name(name)) => Some(name.to_string()),
                    _ => None,
                }))
            }
        }
    }

    fn refuse_unmet_requirements(&self) -> PyResult<()> {
        // Grouped by what they need, so that one sentence names them all.
        let mut unmet: Vec<((&str, &str), Vec<&str>)> = Vec::new();
        for option in &self.table {
            let Some(needed) = option.requires else { continue };
            let given = self.given.get_item(option.name)?.is_some_and(|v| !v.is_none());
            if !given || self.name_given(needed.0)?.as_deref() == Some(needed.1) {
                continue;
            }
            match unmet.iter_mut().find(|(n, _)| *n == needed) {
                Some((_, names)) => names.push(option.name),
                None => unmet.push((needed, vec![option.name])),
            }
        }
        let Some(((other, value), names)) = unmet.into_iter().next() else { return Ok(()) };
        let got = match self.given.get_item(other)?.filter(|v| !v.is_none()) {
            Some(v) => v.repr().map(|r| r.to_string()).unwrap_or_default(),
            None => "its default".to_string(),
        };
        Err(mesh_error(format!(
            "{}: {} only applies to {other}=\"{value}\", got {other}={got}; pass \
                 {other}=\"{value}\" or leave it out",
            self.method.as_str(),
            names.join(" and ")
        )))
    }

    /// The core's entry for `name`. A reader asking for an option its
    /// method's table does not list is a bug of this crate, not the caller's.
    fn spec(&self, name: &str) -> PyResult<&MethodOption> {
        self.table.iter().find(|o| o.name == name).ok_or_else(|| {
            PyRuntimeError::new_err(format!(
                "spherify bug: {} reads option {name:?}, which the core's table does not list",
                self.method.as_str()
            ))
        })
    }

    /// The value given for `name`, taken out; `None` when absent or `None`.
    pub fn take(&self, name: &'static str) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.spec(name)?;
        let value = self.given.get_item(name)?;
        if value.is_some() {
            self.given.del_item(name)?;
        }
        Ok(value.filter(|v| !v.is_none()))
    }

    /// A `MeshError` naming the option and what it must be.
    pub fn bad(&self, name: &str, expected: &str, got: &Bound<'_, PyAny>) -> PyErr {
        let got = got.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".into());
        mesh_error(format!("{}: {name} must be {expected}, got {got}", self.method.as_str()))
    }

    /// A whole number at least the table's minimum (a Python int, not a bool
    /// or a float); `default` when absent.
    pub fn count(&self, name: &'static str, default: usize) -> PyResult<usize> {
        Ok(self.optional_count(name)?.unwrap_or(default))
    }

    /// [`Options::count`], or `None` when absent.
    pub fn optional_count(&self, name: &'static str) -> PyResult<Option<usize>> {
        let OptionKind::Count { minimum } = self.spec(name)?.kind else {
            return Err(PyRuntimeError::new_err(format!("spherify bug: {name} is not a count")));
        };
        let Some(value) = self.take(name)? else { return Ok(None) };
        let expected = format!("an integer >= {minimum}");
        if !value.is_instance_of::<PyInt>() || value.is_instance_of::<PyBool>() {
            return Err(self.bad(name, &expected, &value));
        }
        match value.extract::<i128>().ok().and_then(|v| usize::try_from(v).ok()) {
            Some(v) if v >= minimum => Ok(Some(v)),
            _ => Err(self.bad(name, &format!("{expected} (and at most {})", usize::MAX), &value)),
        }
    }
    /// A real number (an int or a float; not a bool).
    pub fn number(&self, name: &'static str, default: f64) -> PyResult<f64> {
        Ok(self.optional_number(name)?.unwrap_or(default))
    }

    /// A real number, or `None` when absent.
    pub fn optional_number(&self, name: &'static str) -> PyResult<Option<f64>> {
        let Some(value) = self.take(name)? else { return Ok(None) };
        let numeric = value.is_instance_of::<PyFloat>()
            || (value.is_instance_of::<PyInt>() && !value.is_instance_of::<PyBool>());
        match value.extract::<f64>() {
            Ok(v) if numeric => Ok(Some(v)),
            _ => Err(self.bad(name, "a real number", &value)),
        }
    }

    /// True or False.
    pub fn flag(&self, name: &'static str, default: bool) -> PyResult<bool> {
        let Some(value) = self.take(name)? else { return Ok(default) };
        match value.cast::<PyBool>() {
            Ok(b) => Ok(b.is_true()),
            Err(_) => Err(self.bad(name, "True or False", &value)),
        }
    }

    /// A string.
    pub fn string(&self, name: &'static str, default: &str) -> PyResult<String> {
        let Some(value) = self.take(name)? else { return Ok(default.to_string()) };
        match value.cast::<PyString>() {
            Ok(s) => Ok(s.to_cow()?.into_owned()),
            Err(_) => Err(self.bad(name, "a string", &value)),
        }
    }

    /// `weights` by name, with `rho` for "chord" (the table refuses `rho`
    /// with other weights). Which weights a method accepts is the core's
    /// decision; here only the name is translated.
    pub fn weights(&self, default: Weights) -> PyResult<Weights> {
        let name = self.string("weights", default.name())?;
        let default_rho = match default {
            Weights::Chord { rho } => rho,
            _ => 1.0,
        };
        let rho = self.optional_number("rho")?.unwrap_or(default_rho);
        crate::convert::weights(&name, rho)
    }

    /// Ends the reading: every option given was read. One left over is a
    /// table entry its reader forgot (a bug here): it would be ignored.
    pub fn finish(self) -> PyResult<()> {
        let left = self.given_names()?;
        if left.is_empty() {
            return Ok(());
        }
        Err(PyRuntimeError::new_err(format!(
            "spherify bug: method {:?} lists option(s) {} but does not read them",
            self.method.as_str(),
            left.join(", ")
        )))
    }
}
