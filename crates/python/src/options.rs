//! Keyword options of `spherify.embed`, read one by one into the core's
//! parameter types. Every value is checked for its Python type here (a count
//! is an int, not a float or a bool), and an option the method does not know
//! is a `MeshError` that lists the ones it does.

use std::cell::RefCell;

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};
use spherify_sparse::weights::Weights;

use crate::errors::mesh_error;

/// The options given for one method, consumed as the method reads them.
pub struct Options<'py> {
    py: Python<'py>,
    method: &'static str,
    given: Bound<'py, PyDict>,
    /// Every option the method asked for, to list them when one is unknown.
    known: RefCell<Vec<&'static str>>,
}

impl<'py> Options<'py> {
    pub fn new(
        py: Python<'py>,
        method: &'static str,
        given: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Options<'py>> {
        let given = match given {
            Some(d) => d.copy()?,
            None => PyDict::new(py),
        };
        Ok(Options { py, method, given, known: RefCell::new(Vec::new()) })
    }

    pub fn py(&self) -> Python<'py> {
        self.py
    }

    /// The value given for `name`, taken out; `None` when absent or `None`.
    pub fn take(&self, name: &'static str) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.known.borrow_mut().push(name);
        let value = self.given.get_item(name)?;
        if value.is_some() {
            self.given.del_item(name)?;
        }
        Ok(value.filter(|v| !v.is_none()))
    }

    /// A `MeshError` naming the option and what it must be.
    pub fn bad(&self, name: &str, expected: &str, got: &Bound<'_, PyAny>) -> PyErr {
        let got = got.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".into());
        mesh_error(self.py, format!("{}: {name} must be {expected}, got {got}", self.method))
    }

    /// A whole number >= `minimum` (a Python int, not a bool or a float).
    pub fn count(&self, name: &'static str, default: usize, minimum: usize) -> PyResult<usize> {
        let Some(value) = self.take(name)? else { return Ok(default) };
        let expected = format!("an integer >= {minimum}");
        if !value.is_instance_of::<PyInt>() || value.is_instance_of::<PyBool>() {
            return Err(self.bad(name, &expected, &value));
        }
        match value.extract::<i128>().ok().and_then(|v| usize::try_from(v).ok()) {
            Some(v) if v >= minimum => Ok(v),
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
            Ok(s) => Ok(s.to_str()?.to_string()),
            Err(_) => Err(self.bad(name, "a string", &value)),
        }
    }

    /// `weights` by name, with `rho` for "chord". Which weights a method
    /// accepts is the core's decision; here only the name is translated.
    pub fn weights(&self) -> PyResult<Weights> {
        let name = self.string("weights", "uniform")?;
        let rho = self.optional_number("rho")?;
        let weights = crate::convert::weights(self.py, &name, rho.unwrap_or(1.0))?;
        // rho means nothing to the other weights: taking it without a word
        // would hide the caller's mistake.
        if rho.is_some() && !matches!(weights, Weights::Chord { .. }) {
            return Err(mesh_error(
                self.py,
                format!(
                    "{}: rho only applies to weights=\"chord\", got weights={name:?}",
                    self.method
                ),
            ));
        }
        Ok(weights)
    }

    /// Refuses whatever option the method did not read.
    pub fn finish(self) -> PyResult<()> {
        let left: Vec<String> = self
            .given
            .keys()
            .iter()
            .map(|k| k.str().map(|s| s.to_string()))
            .collect::<Result<_, _>>()?;
        if left.is_empty() {
            return Ok(());
        }
        let mut known = self.known.into_inner();
        known.sort_unstable();
        known.dedup();
        Err(mesh_error(
            self.py,
            format!(
                "method {:?} has no option {}; its options are: {}",
                self.method,
                left.iter().map(|k| format!("{k:?}")).collect::<Vec<_>>().join(", "),
                known.join(", ")
            ),
        ))
    }
}
