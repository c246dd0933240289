//! `kanedyn.Mechanism`: loading a mechanism, what `kanedyn check` prints, and `kanedyn eom`'s
//! numbers as NumPy arrays.
//!
//! Loading and evaluation call the same library functions in the same order as the command-line
//! tool (src/bin/kanedyn.rs), so that the arrays equal the CLI's JSON bit for bit; the Python
//! tests hold it to that.
//!
//! One idea, one file: the `Mechanism` class. It runs past 600 lines because every method's
//! Python docstring (parameters, returns, raises) is written where the method is.

use crate::arrays::vector;
use crate::errors::{EngineError, argument_error, guard, to_py};
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::Excitation;
use kanedyn::model::mechanism::Mechanism as Mech;
use numpy::{AllowTypeChange, PyArray2, PyArrayLike1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, TryLockError};

/// Adds `Mechanism` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Mechanism>()
}

/// A validated mechanism: bodies joined in a tree, its generalized speeds and loads.
///
/// Build one with `Mechanism.from_file(path)` or `Mechanism.from_str(text)`. Coordinates `q` and
/// speeds `u` are numbered in joint order over the joints that have a coordinate (all but
/// `Fixed`); `coordinate_names` lists them.
#[pyclass(module = "kanedyn", frozen)]
pub struct Mechanism {
    /// The validated mechanism (the other modules' analyses read it).
    pub(crate) mech: Mech,
    /// Evaluators reused across `eom` calls (building one allocates and factors M at q = 0).
    cache: Mutex<Cache>,
    /// The text it was read from, its file name and the read options, for pickling (None for a
    /// study's mechanism, which pickles with its study).
    origin: Option<Origin>,
}

/// Where a mechanism came from: enough to load it again (`Mechanism.from_str`).
struct Origin {
    /// The file name (for `from_str`, the name given), made absolute when it was loaded.
    name: String,
    /// The file's text.
    text: String,
    allow_read: Vec<PathBuf>,
    allow_any_path: bool,
    max_file_kb: u64,
    max_bodies: usize,
}

/// Evaluators kept between calls, and their work buffers.
#[derive(Default)]
struct Cache {
    /// The mechanism's own loads.
    plain: Option<Kane>,
    /// The last joint-torque override, `(joint, value bits)` in the order given, and its evaluator.
    overridden: Option<(Vec<(usize, u64)>, Kane)>,
    buffers: Buffers,
}

/// The numbers of one `eom` evaluation, in the engine's layout.
#[derive(Default)]
pub struct Buffers {
    /// State `[q; u]`.
    x: Vec<f64>,
    /// `[q̇; u̇]`.
    xdot: Vec<f64>,
    /// M, row-major.
    m: Vec<f64>,
    /// F.
    f: Vec<f64>,
}

/// The CLI's defaults, written as literals in the Python signatures so that `help()` shows them.
const _: () = assert!(ReadPolicy::DEFAULT_MAX_BODIES == 1000 && ReadPolicy::DEFAULT_MAX_FILE_BYTES == 1024 * 1024);

/// Read-policy keyword arguments, the same as the CLI's flags of the same names.
struct PolicyArgs {
    allow_read: Option<Vec<PathBuf>>,
    allow_any_path: bool,
    max_file_kb: u64,
    max_bodies: usize,
}

impl PolicyArgs {
    /// The policy for a mechanism whose catalog parts resolve relative to `base`: the rule of
    /// the CLI's `LoadOptions::policy_for`.
    fn policy(&self, base: &Path) -> ReadPolicy {
        let policy = if self.allow_any_path {
            ReadPolicy::unrestricted()
        } else {
            self.allow_read.iter().flatten().fold(ReadPolicy::within(base), |p, d| p.allow(d))
        };
        policy.with_max_file_bytes(self.max_file_kb.saturating_mul(1024)).with_max_bodies(self.max_bodies)
    }
}

/// `file` as an absolute path (the working folder joined to a relative one, nothing resolved on
/// disk), as text: pickles name their files so, for processes with another working folder.
pub(crate) fn absolute(file: &Path) -> String {
    std::path::absolute(file).unwrap_or_else(|_| file.to_path_buf()).display().to_string()
}

/// The folder of `file`, empty (the current folder) for a bare name: where its parts are looked up.
fn folder_of(file: &Path) -> &Path {
    file.parent().unwrap_or(Path::new(""))
}

impl Mechanism {
    /// Wraps a validated mechanism.
    pub(crate) fn new(mech: Mech) -> Self {
        Self { mech, cache: Mutex::new(Cache::default()), origin: None }
    }

    /// The cache, or a fresh private one when it is in use, so that a call never waits while
    /// holding the interpreter: by another thread, or by this very thread when Python code run
    /// while reading an argument (a mapping's `items()`, an object's `__array__`) calls `eom`
    /// again. A cache that a panic left poisoned is reset (its evaluator may be half updated),
    /// never read.
    fn cache(&self) -> CacheRef<'_> {
        match self.cache.try_lock() {
            Ok(guard) => CacheRef::Shared(guard),
            Err(TryLockError::WouldBlock) => CacheRef::Own(Box::default()),
            Err(TryLockError::Poisoned(poisoned)) => {
                let mut guard = poisoned.into_inner();
                *guard = Cache::default();
                self.cache.clear_poison();
                CacheRef::Shared(guard)
            }
        }
    }

    /// Reads one state vector: any 1-D sequence of numbers (a float64 array is read in place,
    /// anything else goes through `numpy.asarray`); its length must be the number of degrees of
    /// freedom and every value finite (the CLI's `parse_list` rules). Copied into `out`.
    fn read_vector(&self, py: Python<'_>, name: &str, values: &Bound<'_, PyAny>, out: &mut [f64]) -> PyResult<()> {
        // NOTE: extracted here, inside the caller's guard, not as a typed argument: rust-numpy
        // panics when the array is mutably borrowed by Rust code elsewhere (another extension).
        let values: PyArrayLike1<'_, f64, AllowTypeChange> = values
            .extract()
            .map_err(|e| argument_error(py, format!("{name} must be a 1-D sequence of numbers ({e})")))?;
        let n = out.len();
        let array = values.as_array();
        if array.len() != n {
            return Err(argument_error(
                py,
                format!(
                    "{name} needs {n} values (one per degree of freedom: {}), got {}",
                    self.coordinate_list(),
                    array.len()
                ),
            ));
        }
        for (i, (o, &v)) in out.iter_mut().zip(array.iter()).enumerate() {
            if !v.is_finite() {
                return Err(argument_error(py, format!("{name}[{i}] is not finite ({v})")));
            }
            *o = v;
        }
        Ok(())
    }

    fn coordinate_names_vec(&self) -> Vec<&str> {
        self.mech.joints.iter().filter(|j| j.coordinate.is_some()).map(|j| j.name.as_str()).collect()
    }

    fn coordinate_list(&self) -> String {
        self.coordinate_names_vec().join(", ")
    }

    /// The joint-torque overrides as `(joint index, value)`, in the mapping's order.
    pub(crate) fn read_torques(&self, py: Python<'_>, torques: &Bound<'_, PyAny>) -> PyResult<Vec<(usize, f64)>> {
        // A dict is read directly; any other mapping through its `items()`, whose own errors
        // pass through unchanged.
        let items: Vec<Bound<'_, PyAny>> = match torques.cast::<PyDict>() {
            Ok(d) => d.items().iter().collect(),
            Err(_) if !torques.hasattr("items")? => {
                let type_name = torques.get_type().name()?;
                return Err(argument_error(
                    py,
                    format!("joint_torques must be a mapping of joint names to numbers, not {type_name}"),
                ));
            }
            Err(_) => torques.call_method0("items")?.try_iter()?.collect::<PyResult<_>>()?,
        };
        let mut out = Vec::with_capacity(items.len());
        for item in items.iter() {
            let (name, value): (String, f64) = item.extract().map_err(|e| {
                argument_error(py, format!("joint_torques must map joint names to numbers (N·m) ({e})"))
            })?;
            let joint = self.mech.joint_index(name.trim()).ok_or_else(|| {
                let names: Vec<&str> = self.mech.joints.iter().map(|j| j.name.as_str()).collect();
                argument_error(py, format!("joint_torques: unknown joint `{name}` (joints: {})", names.join(", ")))
            })?;
            if !value.is_finite() {
                return Err(argument_error(py, format!("joint_torques[`{name}`]: value is not finite ({value})")));
            }
            out.push((joint, value));
        }
        Ok(out)
    }
}

impl Origin {
    fn new(src: &Source, args: PolicyArgs) -> Self {
        Self {
            name: absolute(&src.file),
            text: src.text.clone(),
            allow_read: args.allow_read.unwrap_or_default(),
            allow_any_path: args.allow_any_path,
            max_file_kb: args.max_file_kb,
            max_bodies: args.max_bodies,
        }
    }
}

/// A borrowed or private cache.
enum CacheRef<'a> {
    Shared(MutexGuard<'a, Cache>),
    Own(Box<Cache>),
}

impl std::ops::Deref for CacheRef<'_> {
    type Target = Cache;
    fn deref(&self) -> &Cache {
        match self {
            CacheRef::Shared(g) => g,
            CacheRef::Own(b) => b,
        }
    }
}

impl std::ops::DerefMut for CacheRef<'_> {
    fn deref_mut(&mut self) -> &mut Cache {
        match self {
            CacheRef::Shared(g) => g,
            CacheRef::Own(b) => b,
        }
    }
}

impl Cache {
    /// The evaluator for these overrides (none: the mechanism's own loads) and the buffers,
    /// building the evaluator the first time, exactly as `kanedyn eom` does: `Kane::new`, then
    /// `set_joint_torque` with a constant for each override, in order.
    fn evaluator(
        &mut self,
        py: Python<'_>,
        mech: &Mech,
        torques: &[(usize, f64)],
    ) -> PyResult<(&mut Kane, &mut Buffers)> {
        let plain = match self.plain.take() {
            Some(kane) => kane,
            None => Kane::new(mech).map_err(|e| to_py(py, &e))?,
        };
        let plain = self.plain.insert(plain);
        if torques.is_empty() {
            return Ok((plain, &mut self.buffers));
        }
        let key: Vec<(usize, u64)> = torques.iter().map(|&(j, v)| (j, v.to_bits())).collect();
        // Taken out and put back (a move, not a copy of the buffers) so that the borrow returned
        // is of the slot itself.
        let entry = match self.overridden.take() {
            Some(entry) if entry.0 == key => entry,
            _ => {
                let mut kane = plain.clone();
                for &(joint, value) in torques {
                    kane.set_joint_torque(joint, Excitation::constant(value));
                }
                (key, kane)
            }
        };
        let (_, kane) = self.overridden.insert(entry);
        Ok((kane, &mut self.buffers))
    }
}

/// `M`, `F`, `q̇` and `u̇` at `x = [q; u]` and time `t` into `out`, by the calls `kanedyn eom`
/// makes, and the CLI's refusal of a non-finite result (its message word for word).
///
/// This is the whole Rust-side cost of `Mechanism.eom`; the overhead benchmark times it alone.
pub fn evaluate(kane: &mut Kane, t: f64, out: &mut Buffers) -> Result<(), String> {
    let n = kane.ndof();
    out.xdot.resize(2 * n, 0.0);
    kane.rhs(t, &out.x, &mut out.xdot)
        .map_err(|e| format!("evaluating the equations of motion: {}", crate::errors::message_of(&e)))?;
    let (q, u) = out.x.split_at(n);
    let (m, f) = kane.mass_matrix_and_forcing(t, q, u);
    out.m.clear();
    for r in 0..n {
        out.m.extend((0..n).map(|c| m[(r, c)]));
    }
    out.f.clear();
    out.f.extend(f.iter().copied());
    // The CLI refuses to print a non-finite number (JSON would carry it as `null`); the same
    // state is refused here with the same words, so both tools agree on what a valid state is.
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if finite(&out.m) && finite(&out.f) && finite(&out.xdot) {
        return Ok(());
    }
    let first_bad =
        |name: &str, v: &[f64]| v.iter().position(|x| !x.is_finite()).map(|i| format!("{name}[{i}] = {}", v[i]));
    let what = (0..n)
        .find_map(|r| first_bad(&format!("M[{r}]"), &out.m[r * n..(r + 1) * n]))
        .or_else(|| first_bad("F", &out.f))
        .or_else(|| first_bad("q̇", &out.xdot[..n]))
        .or_else(|| first_bad("u̇", &out.xdot[n..]))
        .unwrap_or_default();
    Err(format!("the equations of motion overflow at this state: {what} (values too large for f64?)"))
}

/// A new n × n float64 array (C order) holding the row-major `m`.
fn matrix<'py>(py: Python<'py>, n: usize, m: &[f64]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    // SAFETY: the array is new, so nothing else can read or write it while it is filled, and it
    // is C-contiguous, so its buffer is exactly n·n elements in row-major order.
    let array = unsafe { PyArray2::<f64>::new(py, [n, n], false) };
    let data = unsafe { array.as_slice_mut() }
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("new array not contiguous: {e}")))?;
    data.copy_from_slice(m);
    Ok(array)
}

/// A pair as a Python tuple of floats.
fn pair(v: kanedyn::model::math::Vec2) -> (f64, f64) {
    (v.x, v.y)
}

#[pymethods]
impl Mechanism {
    /// Reads and validates a mechanism file (RON).
    ///
    /// Parameters
    /// ----------
    /// path : str or os.PathLike
    ///     The mechanism file.
    /// allow_read : list of paths, optional
    ///     Further folders catalog parts may be read from (by default only the file's own folder
    ///     tree), as the CLI's `--allow-read DIR`.
    /// allow_any_path : bool, default False
    ///     Read parts from any path, as `--allow-any-path`.
    /// max_file_kb : int, default 1024
    ///     Largest file read (the mechanism and each part), kB, as `--max-file-kb`.
    /// max_bodies : int, default 1000
    ///     Most bodies in the mechanism, as `--max-bodies`.
    ///
    /// Returns
    /// -------
    /// Mechanism
    ///
    /// Raises
    /// ------
    /// ReadError
    ///     The file (or a part) cannot be read.
    /// InputError
    ///     The file is wrong; the message and the attributes name the file, the line:column and
    ///     the field, as `kanedyn check FILE` does.
    /// ModelError
    ///     The mechanism cannot be evaluated.
    #[staticmethod]
    #[pyo3(signature = (path, *, allow_read = None, allow_any_path = false, max_file_kb = 1024, max_bodies = 1000))]
    fn from_file(
        py: Python<'_>,
        path: PathBuf,
        allow_read: Option<Vec<PathBuf>>,
        allow_any_path: bool,
        max_file_kb: u64,
        max_bodies: usize,
    ) -> PyResult<Self> {
        guard(|| {
            let args = PolicyArgs { allow_read, allow_any_path, max_file_kb, max_bodies };
            let policy = args.policy(folder_of(&path));
            // `Mech::from_file_with` in two steps, to keep the text for pickling.
            let src = Source::read_with(&path, &policy).map_err(|e| to_py(py, &e))?;
            let mech = Mech::from_source(&src, &policy).map_err(|e| to_py(py, &e))?;
            Ok(Self { origin: Some(Origin::new(&src, args)), ..Self::new(mech) })
        })
    }

    /// Parses and validates mechanism text (RON).
    ///
    /// Parameters
    /// ----------
    /// text : str
    ///     The mechanism, as a file would hold it.
    /// name : str, default "<string>"
    ///     The file name that error messages give; catalog parts are looked up in its folder
    ///     (the current folder for a bare name).
    /// allow_read, allow_any_path, max_file_kb, max_bodies
    ///     As for `Mechanism.from_file`.
    ///
    /// Returns
    /// -------
    /// Mechanism
    ///
    /// Raises
    /// ------
    /// InputError, ReadError, ModelError
    ///     As for `Mechanism.from_file`, located in `name`.
    #[staticmethod]
    #[pyo3(name = "from_str", signature = (text, name = "<string>", *, allow_read = None, allow_any_path = false, max_file_kb = 1024, max_bodies = 1000))]
    fn from_text(
        py: Python<'_>,
        text: &str,
        name: &str,
        allow_read: Option<Vec<PathBuf>>,
        allow_any_path: bool,
        max_file_kb: u64,
        max_bodies: usize,
    ) -> PyResult<Self> {
        guard(|| {
            let src = Source::from_text(name, text);
            let args = PolicyArgs { allow_read, allow_any_path, max_file_kb, max_bodies };
            let policy = args.policy(folder_of(&src.file));
            let mech = Mech::from_source(&src, &policy).map_err(|e| to_py(py, &e))?;
            Ok(Self { origin: Some(Origin::new(&src, args)), ..Self::new(mech) })
        })
    }

    /// The mechanism's name.
    #[getter]
    fn name(&self) -> &str {
        &self.mech.name
    }

    /// The file it was read from; for `from_str`, the name given.
    #[getter]
    fn file(&self) -> Option<String> {
        self.mech.file.as_ref().map(|f| f.display().to_string())
    }

    /// Number of degrees of freedom n (= coordinates = speeds).
    #[getter]
    fn ndof(&self) -> usize {
        self.mech.ndof()
    }

    /// The joints that own the coordinates, in coordinate order: `q[k]` is the coordinate of
    /// joint `coordinate_names[k]`.
    #[getter]
    fn coordinate_names(&self) -> Vec<&str> {
        self.coordinate_names_vec()
    }

    /// What `kanedyn check FILE` prints, as a dict.
    ///
    /// Returns
    /// -------
    /// dict
    ///     name : str
    ///     file : str
    ///         The file read; for `from_str`, the name given.
    ///     degrees_of_freedom : int
    ///     speeds : str
    ///         The generalized speeds: "JointRates" or "AbsoluteAngularVelocities".
    ///     bodies : list of dict
    ///         ``name``; ``mass`` (kg); ``com`` ((x, y) m in the body frame); ``inertia``
    ///         (kg·m² about the centre of mass).
    ///     joints : list of dict, in tree order
    ///         ``name``; ``kind`` ("Revolute", "Prismatic" or "Fixed"); ``axis`` (the unit slide
    ///         axis of a prismatic joint, else None); ``parent`` ("ground" or a body name);
    ///         ``child``; ``at`` ((x, y) m in the parent frame); ``coordinate`` (its index in q);
    ///         ``unit`` ("rad" or "m"); ``damper`` (in ``damper_unit``, "N·m·s/rad" or "N·s/m");
    ///         ``spring`` (None, or ``stiffness`` in ``spring_unit``, "N·m/rad" or "N/m", and
    ///         ``free_angle`` in ``unit``). A fixed joint has None for the coordinate and units.
    ///     loads : dict
    ///         ``gravity`` ((x, y) m/s²) and the counts ``joint_torques``, ``ground_dampers``
    ///         and ``point_forces``.
    ///     total_mass : float
    ///         kg.
    ///     absorbers : list of dict
    ///         Per absorber joint (a path joint or a revolute pendulum on a spinning body), as
    ///         the CLI's "Absorbers" table: ``joint``, ``kind``, ``mass`` (kg) and ``inertia``
    ///         (kg·m²) it carries, ``tuning_order`` n_t, ``nonlinear`` κ (1/m²: n ≈ n_t(1 + κA²)),
    ///         ``travel`` (m, inf when unlimited), ``travel_limit`` (m or None), ``tautochronic``
    ///         ("Exact", "LeadingOrder" or "No"), ``rollers`` (None, or the rollers carrying a
    ///         translating path absorber: ``count``, ``mass`` kg and ``inertia`` kg·m² each,
    ///         ``radius`` m, ``spread`` m; ``tuning_order``, ``nonlinear`` and ``tautochronic``
    ///         then include them) and ``tuning_order_without_rollers``.
    fn check<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let mech = &self.mech;
            let out = PyDict::new(py);
            out.set_item("name", &mech.name)?;
            out.set_item("file", self.file())?;
            out.set_item("degrees_of_freedom", mech.ndof())?;
            out.set_item("speeds", format!("{:?}", mech.speeds))?;
            let bodies = PyList::empty(py);
            for b in &mech.bodies {
                let d = PyDict::new(py);
                d.set_item("name", &b.name)?;
                d.set_item("mass", b.inertia.mass)?;
                d.set_item("com", pair(b.inertia.com))?;
                d.set_item("inertia", b.inertia.i_com)?;
                bodies.append(d)?;
            }
            out.set_item("bodies", bodies)?;
            let joints = PyList::empty(py);
            for (k, j) in mech.joints.iter().enumerate() {
                let d = PyDict::new(py);
                d.set_item("name", &j.name)?;
                d.set_item("kind", j.kind.name())?;
                d.set_item("axis", j.kind.slide_axis().map(|a| (a.x, a.y)))?;
                d.set_item("parent", j.parent.map_or("ground", |p| mech.bodies[p].name.as_str()))?;
                d.set_item("child", &mech.bodies[k].name)?;
                d.set_item("at", pair(j.at))?;
                d.set_item("coordinate", j.coordinate)?;
                // The CLI's rule: per radian for a turn, per metre for a slide.
                let (per, unit) = if j.kind.rotates() { ("N·m", "rad") } else { ("N", "m") };
                let has = |text: String| j.coordinate.map(|_| text);
                d.set_item("unit", has(unit.to_string()))?;
                d.set_item("damper_unit", has(format!("{per}·s/{unit}")))?;
                d.set_item("spring_unit", has(format!("{per}/{unit}")))?;
                d.set_item("damper", j.damper)?;
                let spring = match j.spring {
                    Some(s) => {
                        let sd = PyDict::new(py);
                        sd.set_item("stiffness", s.stiffness)?;
                        sd.set_item("free_angle", s.free_angle)?;
                        Some(sd)
                    }
                    None => None,
                };
                d.set_item("spring", spring)?;
                joints.append(d)?;
            }
            out.set_item("joints", joints)?;
            let l = &mech.loads;
            let loads = PyDict::new(py);
            loads.set_item("gravity", pair(l.gravity))?;
            loads.set_item("joint_torques", l.joint_torques.len())?;
            loads.set_item("ground_dampers", l.ground_dampers.len())?;
            loads.set_item("point_forces", l.point_forces.len())?;
            out.set_item("loads", loads)?;
            out.set_item("total_mass", mech.total_mass())?;
            // The absorber properties `kanedyn check` prints under "## Absorbers".
            let absorbers = PyList::empty(py);
            for a in kanedyn::model::absorber::absorbers(mech) {
                let d = PyDict::new(py);
                d.set_item("joint", &a.joint)?;
                d.set_item("kind", a.kind)?;
                d.set_item("mass", a.mass)?;
                d.set_item("inertia", a.inertia)?;
                d.set_item("tuning_order", a.tuning_order())?;
                d.set_item("nonlinear", a.nonlinear)?;
                d.set_item("travel", a.travel)?;
                d.set_item("travel_limit", a.travel_limit)?;
                d.set_item("tautochronic", format!("{:?}", a.tautochronic))?;
                // A translating absorber on rollers: n_t and κ above include them.
                let rollers = match a.rollers {
                    Some(r) => {
                        let rd = PyDict::new(py);
                        rd.set_item("count", r.count)?;
                        rd.set_item("mass", r.mass)?;
                        rd.set_item("inertia", r.inertia)?;
                        rd.set_item("radius", r.radius)?;
                        rd.set_item("spread", r.spread)?;
                        Some(rd)
                    }
                    None => None,
                };
                d.set_item("rollers", rollers)?;
                d.set_item("tuning_order_without_rollers", a.plain_tuning_order_squared.sqrt())?;
                absorbers.append(d)?;
            }
            out.set_item("absorbers", absorbers)?;
            Ok(out)
        })
    }

    /// The equations of motion `M(q) u̇ = F(q, u, t)`, `q̇ = W⁻¹ u` at one state.
    ///
    /// The numbers are those `kanedyn eom FILE --q … --u … --t … --joint-torque NAME=VALUE`
    /// prints, bit for bit.
    ///
    /// Parameters
    /// ----------
    /// q : array_like, shape (n,)
    ///     Coordinates in coordinate order (`coordinate_names`): rad for a revolute joint, m for
    ///     a prismatic one.
    /// u : array_like, shape (n,)
    ///     Generalized speeds in the mechanism's speed definition (`check()["speeds"]`).
    /// t : float, default 0.0
    ///     Time, s, for time-dependent loads.
    /// joint_torques : dict of str to float, optional
    ///     Replaces the applied torque (N·m) of each named joint by a constant, as
    ///     `--joint-torque NAME=VALUE`; the joint's spring and damper stay.
    ///
    /// Returns
    /// -------
    /// M : ndarray, shape (n, n)
    ///     Mass matrix (kg·m² for rotational speeds), symmetric positive definite.
    /// F : ndarray, shape (n,)
    ///     Forcing: applied forces minus the inertia forces at u̇ = 0 (N·m for rotational speeds).
    /// qdot : ndarray, shape (n,)
    ///     q̇ = W⁻¹ u.
    /// udot : ndarray, shape (n,)
    ///     u̇ = M⁻¹ F.
    ///
    /// Raises
    /// ------
    /// ArgumentError
    ///     q or u of the wrong length or not finite, t not finite, an unknown joint.
    /// EngineError
    ///     M is not positive definite at this state, or a result overflows f64.
    ///
    /// Examples
    /// --------
    /// >>> m = kanedyn.Mechanism.from_file("examples/cpva.ron")
    /// >>> M, F, qdot, udot = m.eom([12.5, -0.4], [104.7, -20.0], joint_torques={"spin": 250.0})
    #[pyo3(signature = (q, u, t = 0.0, joint_torques = None))]
    fn eom<'py>(
        &self,
        py: Python<'py>,
        q: Bound<'py, PyAny>,
        u: Bound<'py, PyAny>,
        t: f64,
        joint_torques: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let n = self.mech.ndof();
            let mut cache = self.cache();
            // Arguments are checked in the CLI's order (q, u, t, then the overrides).
            let x = &mut cache.buffers.x;
            x.resize(2 * n, 0.0);
            let (xq, xu) = x.split_at_mut(n);
            self.read_vector(py, "q", &q, xq)?;
            self.read_vector(py, "u", &u, xu)?;
            if !t.is_finite() {
                return Err(argument_error(py, format!("t must be finite, got {t}")));
            }
            let torques = match &joint_torques {
                Some(jt) => self.read_torques(py, jt)?,
                None => Vec::new(),
            };
            let (kane, buf) = cache.evaluator(py, &self.mech, &torques)?;
            evaluate(kane, t, buf).map_err(EngineError::new_err)?;
            let m = matrix(py, n, &buf.m)?;
            let f = vector(py, &buf.f);
            let qdot = vector(py, &buf.xdot[..n]);
            let udot = vector(py, &buf.xdot[n..]);
            PyTuple::new(py, [m.into_any(), f.into_any(), qdot.into_any(), udot.into_any()])
        })
    }

    /// Times the Rust side of `eom` alone: `calls` evaluations at (q, u, t) with the mechanism's
    /// own loads, in a loop without Python. Returns seconds per call. For the overhead benchmark
    /// (python/bench/eom_overhead.py); not part of the API.
    #[pyo3(name = "_time_rust_eom", signature = (q, u, t, calls))]
    fn time_rust_eom(
        &self,
        py: Python<'_>,
        q: Bound<'_, PyAny>,
        u: Bound<'_, PyAny>,
        t: f64,
        calls: usize,
    ) -> PyResult<f64> {
        guard(|| {
            let n = self.mech.ndof();
            let mut cache = self.cache();
            let x = &mut cache.buffers.x;
            x.resize(2 * n, 0.0);
            let (xq, xu) = x.split_at_mut(n);
            self.read_vector(py, "q", &q, xq)?;
            self.read_vector(py, "u", &u, xu)?;
            let (kane, buf) = cache.evaluator(py, &self.mech, &[])?;
            let start = std::time::Instant::now();
            for _ in 0..calls {
                evaluate(kane, std::hint::black_box(t), buf).map_err(EngineError::new_err)?;
                std::hint::black_box(&buf.m);
            }
            Ok(start.elapsed().as_secs_f64() / calls.max(1) as f64)
        })
    }

    /// Pickling: the mechanism's text, its file name (made absolute when it was loaded, so that
    /// parts resolve alike from another working folder) and the read options; unpickling parses the
    /// text again (`Mechanism.from_str`), so the copy equals the original bit for bit; catalog
    /// parts are read again relative to the file name (a worker elsewhere needs them at the same
    /// path). A study's mechanism (`Study.mechanism`) pickles with its study instead.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let Some(o) = &self.origin else {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "mechanism `{}` is a study's: pickle the study, or load the mechanism with Mechanism.from_file",
                self.mech.name
            )));
        };
        let restore = py.import("kanedyn._pickle")?.getattr("restore_mechanism")?;
        let allow_read: Vec<String> = o.allow_read.iter().map(|p| p.display().to_string()).collect();
        let args =
            (o.text.as_str(), absolute(Path::new(&o.name)), allow_read, o.allow_any_path, o.max_file_kb, o.max_bodies)
                .into_pyobject(py)?;
        Ok((restore, args))
    }

    fn __repr__(&self) -> String {
        format!("<kanedyn.Mechanism `{}`: {} degrees of freedom>", self.mech.name, self.mech.ndof())
    }
}
