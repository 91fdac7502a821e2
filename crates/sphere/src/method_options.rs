//! The keyword options of every method, written once.
//!
//! Which options a method takes, of what kind, with which default, which
//! allowed names and which other option they need is a fact of the core:
//! it lives in this one table. The bindings read `sp.embed`'s and
//! `sp.improve`'s keywords through it (a keyword its method does not list is
//! refused, naming the ones it does), and Python's API, the batch and the
//! command line take their option names, defaults, choices and help from it
//! (`_core.method_options()`): none of them keeps a list of its own.
//!
//! Defaults are read off each method's `Default` parameters, so the table
//! cannot drift from what the method runs with.

use spherify_sparse::weights::Weights;

use crate::embed::MethodName;
use crate::methods::alexa::AlexaParams;
use crate::methods::gotsman::GotsmanParams;
use crate::methods::progressive::distortion_energy::Energy;
use crate::methods::progressive::improve::ImproveParams;
use crate::methods::progressive::ProgressiveParams;
use crate::methods::radial::Center;
use crate::methods::relaxation::RelaxationParams;
use crate::methods::theta_phi::symmetry::SymmetryParams;
use crate::methods::theta_phi::{PoleChoice, ThetaPhiParams};

/// What an option's value may be.
#[derive(Debug, Clone, PartialEq)]
pub enum OptionKind {
    /// A whole number, at least `minimum`.
    Count { minimum: usize },
    /// A finite or infinite real number (the method decides which it accepts).
    Number,
    /// True or false.
    Flag,
    /// One of `choices`.
    Name { choices: Vec<&'static str> },
    /// One of `choices`, or a (north, south) pair of vertex ids.
    NameOrVertexPair { choices: Vec<&'static str> },
    /// One of `choices`, or a point (x, y, z).
    NameOrPoint { choices: Vec<&'static str> },
    /// One point (x, y, z) per vertex.
    Points,
}

impl OptionKind {
    /// The kind's name, as the bindings and the docs spell it.
    pub fn name(&self) -> &'static str {
        match self {
            OptionKind::Count { .. } => "count",
            OptionKind::Number => "number",
            OptionKind::Flag => "flag",
            OptionKind::Name { .. } => "name",
            OptionKind::NameOrVertexPair { .. } => "name_or_vertex_pair",
            OptionKind::NameOrPoint { .. } => "name_or_point",
            OptionKind::Points => "points",
        }
    }

    /// The allowed names, for the kinds that have them.
    pub fn choices(&self) -> &[&'static str] {
        match self {
            OptionKind::Name { choices }
            | OptionKind::NameOrVertexPair { choices }
            | OptionKind::NameOrPoint { choices } => choices,
            _ => &[],
        }
    }
}

/// One value an option can take.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OptionValue {
    Count(usize),
    Number(f64),
    Flag(bool),
    Name(&'static str),
}

/// What a method uses when an option is not given.
#[derive(Debug, Clone, PartialEq)]
pub enum OptionDefault {
    /// This value.
    Value(OptionValue),
    /// Nothing: the method decides (the option's help says how).
    Unset,
    /// A value that depends on another option's name: `(name, value)` pairs.
    Depends { on: &'static str, values: Vec<(&'static str, OptionValue)> },
}

/// One keyword option of a method.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodOption {
    pub name: &'static str,
    pub kind: OptionKind,
    pub default: OptionDefault,
    /// The option means something only when another option has this name
    /// (`symmetry_eps` with `poles = "symmetry"`); given otherwise, it is refused.
    pub requires: Option<(&'static str, &'static str)>,
    /// One line for `--help` and the docs.
    pub help: &'static str,
}

impl MethodOption {
    fn new(name: &'static str, kind: OptionKind, default: OptionDefault) -> MethodOption {
        MethodOption { name, kind, default, requires: None, help: "" }
    }

    fn help(mut self, help: &'static str) -> MethodOption {
        self.help = help;
        self
    }

    fn requires(mut self, option: &'static str, name: &'static str) -> MethodOption {
        self.requires = Some((option, name));
        self
    }
}

fn count(name: &'static str, minimum: usize, default: usize) -> MethodOption {
    MethodOption::new(
        name,
        OptionKind::Count { minimum },
        OptionDefault::Value(OptionValue::Count(default)),
    )
}

fn number(name: &'static str, default: f64) -> MethodOption {
    MethodOption::new(name, OptionKind::Number, OptionDefault::Value(OptionValue::Number(default)))
}

fn flag(name: &'static str, default: bool) -> MethodOption {
    MethodOption::new(name, OptionKind::Flag, OptionDefault::Value(OptionValue::Flag(default)))
}

fn weights(choices: &[&'static str], default: Weights) -> [MethodOption; 2] {
    let rho = match default {
        Weights::Chord { rho } => rho,
        _ => 1.0,
    };
    [
        MethodOption::new(
            "weights",
            OptionKind::Name { choices: choices.to_vec() },
            OptionDefault::Value(OptionValue::Name(default.name())),
        )
        .help("the edge weights (thesis 4.4)"),
        number("rho", rho)
            .requires("weights", "chord")
            .help("the exponent of the chord weights, |x_i - x_j|^-rho"),
    ]
}

/// The start of the iterative methods (eq. 5.13): a centre or points.
fn start() -> [MethodOption; 2] {
    [
        MethodOption::new(
            "center",
            OptionKind::NameOrPoint { choices: vec!["centroid"] },
            OptionDefault::Value(OptionValue::Name("centroid")),
        )
        .help("project from the vertex mean or from this point (eq. 5.11, 5.14)"),
        MethodOption::new("initial", OptionKind::Points, OptionDefault::Unset)
            .help("start from these points, one per vertex (not with center)"),
    ]
}

/// Most iterations, how often to test validity, the tolerance and whether
/// running out of iterations is an error: the iterative methods' stop rule.
fn stop_rule(
    max_iter: usize,
    check_every: Option<usize>,
    tol: f64,
    strict: bool,
) -> Vec<MethodOption> {
    let mut options = vec![count("max_iter", 0, max_iter).help("most iterations")];
    if let Some(every) = check_every {
        options
            .push(count("check_every", 1, every).help("test validity every this many iterations"));
    }
    options.push(number("tol", tol).help("stop when the largest move is below this"));
    options.push(flag("strict", strict).help("raise ConvergenceError unless converged"));
    options
}

fn energy(default: Energy) -> MethodOption {
    MethodOption::new(
        "energy",
        OptionKind::Name { choices: Energy::NAMES.to_vec() },
        OptionDefault::Value(OptionValue::Name(default.name())),
    )
    .help("the distortion energy it lowers")
}

/// `max_iter` and `tol` of the progressive method, whose defaults depend on
/// the energy ([`ProgressiveParams::for_energy`]).
fn progressive_stop_rule() -> [MethodOption; 2] {
    let per_energy = |value: fn(&ProgressiveParams) -> OptionValue| OptionDefault::Depends {
        on: "energy",
        values: Energy::NAMES
            .iter()
            .filter_map(|&name| Energy::from_name(name))
            .map(|e| (e.name(), value(&ProgressiveParams::for_energy(e))))
            .collect(),
    };
    [
        MethodOption::new(
            "max_iter",
            OptionKind::Count { minimum: 0 },
            per_energy(|p| OptionValue::Count(p.max_iter)),
        )
        .help("most sweeps of the final optimisation"),
        MethodOption::new(
            "tol",
            OptionKind::Number,
            per_energy(|p| OptionValue::Number(p.tolerance)),
        )
        .help("stop when a sweep lowers the energy by less than this fraction"),
    ]
}

impl MethodName {
    /// The keyword options of this method, in the order the docs list them.
    /// [`MethodName::Improve`] lists `sp.improve`'s; [`MethodName::Points`]
    /// has none.
    pub fn options(self) -> Vec<MethodOption> {
        match self {
            MethodName::Radial => {
                let default = match Center::default() {
                    Center::Kernel => "kernel",
                    Center::Centroid | Center::Point(_) => "centroid",
                };
                vec![MethodOption::new(
                    "center",
                    OptionKind::NameOrPoint { choices: vec!["kernel", "centroid"] },
                    OptionDefault::Value(OptionValue::Name(default)),
                )
                .help("project from the kernel's deepest point, the vertex mean or this point")]
            }
            MethodName::Relaxation => {
                let d = RelaxationParams::default();
                let mut options = weights(&Weights::NAMES, d.weights).to_vec();
                options.extend(stop_rule(d.max_iter, Some(d.check_every), d.tol, d.strict));
                options.extend(start());
                options
            }
            MethodName::Alexa => {
                let d = AlexaParams::default();
                let mut options = vec![MethodOption::new("c", OptionKind::Number, OptionDefault::Unset)
                    .help("a constant step (1 is Alexa's robust choice); unset: 1 / longest edge (eq. 5.19)")];
                options.extend(stop_rule(d.max_iter, Some(d.check_every), d.tol, d.strict));
                options.extend(start());
                options
            }
            MethodName::Gotsman => {
                let d = GotsmanParams::default();
                let mut options = weights(&GotsmanParams::WEIGHTS, d.weights).to_vec();
                options.extend(stop_rule(d.max_iter, None, d.tol, d.strict));
                options.extend(start());
                options
            }
            MethodName::ThetaPhi => {
                let d = ThetaPhiParams::default();
                let symmetry = SymmetryParams::default();
                let mut options = vec![MethodOption::new(
                    "poles",
                    OptionKind::NameOrVertexPair { choices: PoleChoice::NAMES.to_vec() },
                    OptionDefault::Value(OptionValue::Name(d.poles.name())),
                )
                .help("how to choose the poles and the cut (6.2)")];
                options.extend(weights(&ThetaPhiParams::WEIGHTS, d.weights));
                options.push(
                    count("max_refinements", 0, d.max_refinements)
                        .help("most double-double refinement steps per embedding"),
                );
                options.push(
                    MethodOption::new("symmetry_eps", OptionKind::Number, OptionDefault::Unset)
                        .requires("poles", "symmetry")
                        .help("band half-width around the symmetry plane in mesh units (unset: automatic)"),
                );
                options.push(
                    number("symmetry_max_score", symmetry.max_score)
                        .requires("poles", "symmetry")
                        .help("the largest asymmetry score a plane may have"),
                );
                options
            }
            MethodName::Progressive => {
                let mut options = vec![energy(ProgressiveParams::default().energy)];
                options.extend(progressive_stop_rule());
                options
            }
            MethodName::Improve => {
                let d = ImproveParams::default();
                vec![
                    energy(d.energy),
                    count("max_iter", 0, d.max_iter).help("most sweeps"),
                    number("tol", d.tolerance)
                        .help("stop when a sweep lowers the energy by less than this fraction"),
                    MethodOption::new(
                        "max_vertices",
                        OptionKind::Count { minimum: 4 },
                        OptionDefault::Unset,
                    )
                    .help(
                        "with landmarks: most vertices a layout may refine the mesh to \
                         (unset: 16 times the mesh's, or 200,000 more)",
                    ),
                ]
            }
            MethodName::Points => Vec::new(),
        }
    }

    /// The option called `name`, if this method takes it.
    pub fn option(self, name: &str) -> Option<MethodOption> {
        self.options().into_iter().find(|o| o.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_requirements_point_at_real_names() {
        for method in MethodName::ALL.into_iter().chain([MethodName::Improve]) {
            let options = method.options();
            let mut names: Vec<_> = options.iter().map(|o| o.name).collect();
            names.sort_unstable();
            names.dedup();
            assert_eq!(names.len(), options.len(), "{method}: an option listed twice");
            for option in &options {
                assert!(!option.help.is_empty(), "{method}.{} has no help", option.name);
                if let Some((other, value)) = option.requires {
                    let other = method.option(other).expect("requires names an option");
                    assert!(other.kind.choices().contains(&value), "{method}.{}", option.name);
                }
                if let OptionDefault::Value(OptionValue::Name(name)) = option.default {
                    assert!(option.kind.choices().contains(&name), "{method}.{}", option.name);
                }
            }
        }
    }

    #[test]
    fn defaults_are_the_methods_own() {
        let theta_phi = MethodName::ThetaPhi;
        assert_eq!(
            theta_phi.option("max_refinements").unwrap().default,
            OptionDefault::Value(OptionValue::Count(ThetaPhiParams::default().max_refinements))
        );
        let OptionDefault::Depends { on, values } =
            MethodName::Progressive.option("max_iter").unwrap().default
        else {
            panic!("progressive's max_iter depends on the energy")
        };
        assert_eq!(on, "energy");
        assert_eq!(values.len(), Energy::NAMES.len());
        assert!(values.contains(&("isometric", OptionValue::Count(5))));
    }
}
