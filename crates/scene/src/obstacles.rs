//! `[[obstacles]]` and `[contact]`: the scene's rigid obstacles, checked when the scene is parsed
//! (before any mesh is built), and their contact with a built mesh ([`tetfem::contact`]).

use nalgebra::{Rotation3, Vector3};
use tetfem::TetMesh;
use tetfem::base::error::Result;
use tetfem::contact::{Contact, ContactParameters, Obstacle, ObstacleMotion, Shape};
use tetfem::mesh::CellType;

use super::{AnalysisKind, ObstacleKind, Scene};

impl Scene {
    /// The `[[obstacles]]` as the library's obstacles, each key checked: errors name the key
    /// (`obstacles[i].radius`) and its line. Also refuses obstacles with `analysis.accuracy`
    /// (the accuracy search solves without contact). A motion: dynamic scenes take `velocity` or
    /// `displacement` with `amplitude`; static ones `displacement` (with an optional
    /// `amplitude`) over the pseudo-time t ∈ [0, 1], not `velocity`. What obstacles may be
    /// combined with (modal, Newmark, 10-node tets, …) is the library's rule
    /// ([`Scene::combination`]).
    pub(crate) fn check_obstacles(&self) -> Result<Vec<Obstacle>> {
        let mut obstacles = Vec::with_capacity(self.spec.obstacles.len());
        let kind = self
            .spec
            .analysis
            .as_ref()
            .map_or(AnalysisKind::Static, |a| a.get_ref().kind);
        let named = match self
            .spec
            .obstacles
            .iter()
            .any(|o| o.get_ref().amplitude.is_some())
        {
            true => self.named_amplitudes()?,
            false => Default::default(),
        };
        for (i, spanned) in self.spec.obstacles.iter().enumerate() {
            let span = spanned.span();
            let o = spanned.get_ref();
            let key = |field: &str| format!("obstacles[{i}].{field}");
            let err = |field: &str, msg: String| self.error(&key(field), &span, msg);
            self.refuse_obstacle_here(i, &span)?;
            let name = o.name.clone().unwrap_or_else(|| format!("obstacle{i}"));
            let valid_name = !name.is_empty()
                && name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
            if !valid_name {
                return Err(err(
                    "name",
                    format!(
                        "'{name}': use letters, digits, '_' and '-' only (it names CSV columns)"
                    ),
                ));
            }
            if obstacles.iter().any(|p: &Obstacle| p.name() == name) {
                return Err(err(
                    "name",
                    format!("'{name}' is used by an earlier obstacle"),
                ));
            }
            let obstacle = self.obstacle_shape(i, o, &span, name)?;
            let friction = o.friction.unwrap_or(0.0);
            if friction.is_nan() || friction < 0.0 || friction.is_infinite() {
                return Err(err(
                    "friction",
                    format!("{friction}: must be finite and ≥ 0"),
                ));
            }
            let obstacle = obstacle
                .and_then(|ob| ob.with_friction(friction))
                .map_err(|e| err("kind", e.to_string()))?;
            let obstacle = match self.obstacle_motion(i, o, &span, kind, &named)? {
                Some(motion) => obstacle
                    .with_motion(motion)
                    .map_err(|e| err("velocity", e.to_string()))?,
                None => obstacle,
            };
            obstacles.push(self.obstacle_spin(i, o, &span, kind, obstacle)?);
        }
        if let Some(contact) = &self.spec.contact {
            if obstacles.is_empty() {
                return Err(self.error(
                    "contact",
                    &contact.span(),
                    "[contact] without [[obstacles]]: add an obstacle or remove the table",
                ));
            }
            let c = contact.get_ref();
            for (field, value) in [
                ("activation_distance", c.activation_distance),
                ("stiffness", c.stiffness),
                ("slip_distance", c.slip_distance),
                ("slip_velocity", c.slip_velocity),
            ] {
                if let Some(v) = value
                    && (v.is_nan() || v <= 0.0 || v.is_infinite())
                {
                    return Err(self.error(
                        &format!("contact.{field}"),
                        &contact.span(),
                        format!("{v}: must be finite and > 0"),
                    ));
                }
            }
        }
        Ok(obstacles)
    }

    /// Refuses `[[obstacles]]` entry `i` with `analysis.accuracy` (the scenes' accuracy search
    /// solves without contact); what else contact may not be combined with is the library's
    /// rule ([`Scene::combination`]).
    fn refuse_obstacle_here(&self, i: usize, span: &std::ops::Range<usize>) -> Result<()> {
        let err =
            |field: &str, msg: String| self.error(&format!("obstacles[{i}].{field}"), span, msg);
        if let Some(analysis) = &self.spec.analysis
            && analysis.get_ref().accuracy.is_some()
        {
            return Err(err(
                "kind",
                "[[obstacles]] with analysis.accuracy is not supported: the accuracy search \
                 solves without contact; give the mesh's cells instead"
                    .into(),
            ));
        }
        Ok(())
    }

    /// The shape of `[[obstacles]]` entry `i` named `name` from its keys, each checked (the
    /// outer error: one not of its kind, a missing or non-finite one, naming the key and line);
    /// the inner result is the library constructor's (reported at `kind` after the friction
    /// check).
    fn obstacle_shape(
        &self,
        i: usize,
        o: &super::spec::ObstacleSpec,
        span: &std::ops::Range<usize>,
        name: String,
    ) -> Result<Result<Obstacle>> {
        let err =
            |field: &str, msg: String| self.error(&format!("obstacles[{i}].{field}"), span, msg);
        let allowed: &[&str] = match o.kind {
            ObstacleKind::HalfSpace => &["point", "normal"],
            ObstacleKind::Sphere => &["center", "radius"],
            ObstacleKind::Box if o.min.is_some() || o.max.is_some() => &["min", "max"],
            ObstacleKind::Box => &["center", "half_extents", "rotation_deg"],
        };
        let given = [
            ("point", o.point.is_some()),
            ("normal", o.normal.is_some()),
            ("center", o.center.is_some()),
            ("radius", o.radius.is_some()),
            ("min", o.min.is_some()),
            ("max", o.max.is_some()),
            ("half_extents", o.half_extents.is_some()),
            ("rotation_deg", o.rotation_deg.is_some()),
        ];
        if let Some((field, _)) = given.iter().find(|(f, g)| *g && !allowed.contains(f)) {
            return Err(err(
                field,
                format!(
                    "a {:?} obstacle takes {} (not {field})",
                    o.kind,
                    allowed.join(", ")
                ),
            ));
        }
        let required = |field: &str, value: Option<[f64; 3]>| {
            let v = value
                .ok_or_else(|| err(field, format!("missing: a {:?} obstacle needs it", o.kind)))?;
            if v.iter().all(|x| x.is_finite()) {
                Ok(Vector3::from(v))
            } else {
                Err(err(field, format!("{v:?}: every component must be finite")))
            }
        };
        let obstacle = match o.kind {
            ObstacleKind::HalfSpace => {
                let point = required("point", o.point)?;
                let normal = required("normal", o.normal)?;
                if normal.norm() == 0.0 {
                    return Err(err("normal", "[0, 0, 0]: must be non-zero".into()));
                }
                Obstacle::half_space(name, point, normal)
            }
            ObstacleKind::Sphere => {
                let center = required("center", o.center)?;
                let radius = o
                    .radius
                    .ok_or_else(|| err("radius", "missing: a sphere obstacle needs it".into()))?;
                if radius.is_nan() || radius <= 0.0 || radius.is_infinite() {
                    return Err(err("radius", format!("{radius}: must be finite and > 0")));
                }
                Obstacle::sphere(name, center, radius)
            }
            ObstacleKind::Box if o.min.is_some() || o.max.is_some() => {
                let min = required("min", o.min)?;
                let max = required("max", o.max)?;
                if let Some(axis) = (0..3).find(|&k| max[k] <= min[k]) {
                    return Err(err(
                        "max",
                        format!(
                            "{:?}: must exceed min = {:?} on every axis (axis {axis} does not)",
                            o.max.unwrap_or_default(),
                            o.min.unwrap_or_default()
                        ),
                    ));
                }
                Obstacle::aligned_box(name, min, max)
            }
            ObstacleKind::Box => {
                let center = required("center", o.center)?;
                let half = required("half_extents", o.half_extents)?;
                if half.iter().any(|h| *h <= 0.0) {
                    return Err(err(
                        "half_extents",
                        format!("{:?}: each must be > 0", half.as_slice()),
                    ));
                }
                let angle = o.rotation_deg.unwrap_or(0.0);
                if !angle.is_finite() {
                    return Err(err("rotation_deg", format!("{angle}: must be finite")));
                }
                let rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), angle.to_radians());
                Obstacle::oriented_box(name, center, half, rotation)
            }
        };
        Ok(obstacle)
    }

    /// `obstacle` (`[[obstacles]]` entry `i`) with its `spin` about `spin_axis_point` (default
    /// the sphere's centre or the half-space's point), in an analysis of `kind`. Errors name
    /// the key and line: a spin in a static scene (no seconds), a point without a spin, a
    /// non-finite vector, a spin that would move the shape (the library's rule,
    /// [`Obstacle::with_spin`]).
    fn obstacle_spin(
        &self,
        i: usize,
        o: &super::spec::ObstacleSpec,
        span: &std::ops::Range<usize>,
        kind: AnalysisKind,
        obstacle: Obstacle,
    ) -> Result<Obstacle> {
        let err =
            |field: &str, msg: String| self.error(&format!("obstacles[{i}].{field}"), span, msg);
        let omega = match (o.spin, o.spin_axis_point) {
            (None, None) => return Ok(obstacle),
            (None, Some(_)) => {
                return Err(err(
                    "spin_axis_point",
                    "places the axis of a spin: give spin = [..] (rad/s) with it".into(),
                ));
            }
            (Some(w), _) if kind == AnalysisKind::Static => {
                return Err(err(
                    "spin",
                    format!(
                        "{w:?}: a static solve has no seconds for a spin to act over (spinning \
                         obstacles are for dynamic scenes)"
                    ),
                ));
            }
            (Some(w), _) => Vector3::from(w),
        };
        let pivot = match (o.spin_axis_point, obstacle.shape()) {
            (Some(p), _) => Vector3::from(p),
            (None, Shape::Sphere { center, .. }) => *center,
            (None, Shape::HalfSpace { point, .. }) => *point,
            (None, Shape::Box { center, .. }) => *center,
        };
        obstacle.with_spin(omega, pivot).map_err(|e| {
            // The library names the vector at fault: report it at that key.
            let message = e.to_string();
            match message.contains(": spin_axis_point =") {
                true => err("spin_axis_point", message),
                false => err("spin", message),
            }
        })
    }

    /// The motion of `[[obstacles]]` entry `i` (`None`: fixed) in an analysis of `kind`:
    /// `velocity`, or `displacement` with `amplitude` (a name of `named` or inline). A static
    /// scene moves the obstacle over the pseudo-time t ∈ [0, 1] of its load steps (load step k
    /// of n at t = k/n): `displacement` alone is scaled by a ramp from 0 at t = 0 to 1 at t = 1
    /// (reached at the last load step), with `amplitude` by a(t); `velocity` is refused there
    /// (a static solve has no seconds). Errors name the key and line: both kinds, an amplitude
    /// without displacement, a displacement without amplitude in a dynamic scene, a non-finite
    /// vector, a velocity in a static scene.
    fn obstacle_motion(
        &self,
        i: usize,
        o: &super::spec::ObstacleSpec,
        span: &std::ops::Range<usize>,
        kind: AnalysisKind,
        named: &std::collections::HashMap<String, tetfem::bc::amplitude::Amplitude>,
    ) -> Result<Option<ObstacleMotion>> {
        let key = |field: &str| format!("obstacles[{i}].{field}");
        let err = |field: &str, msg: String| self.error(&key(field), span, msg);
        let finite = |field: &str, v: [f64; 3]| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(Vector3::from(v))
            } else {
                Err(err(field, format!("{v:?}: every component must be finite")))
            }
        };
        let motion = match (o.velocity, o.displacement, &o.amplitude) {
            (None, None, None) => return Ok(None),
            (Some(_), Some(_), _) => {
                return Err(err(
                    "displacement",
                    "give velocity or displacement (with amplitude), not both".into(),
                ));
            }
            (Some(_), None, Some(_)) => {
                return Err(err(
                    "amplitude",
                    "scales displacement; a velocity is constant (give displacement instead)"
                        .into(),
                ));
            }
            (Some(v), None, None) if kind == AnalysisKind::Static => {
                return Err(err(
                    "velocity",
                    format!(
                        "{v:?}: a static solve has no seconds for a velocity to act over; give \
                         displacement = [..] (m) instead: the obstacle is moved by \
                         displacement·t over the load steps' pseudo-time t = k/n and reaches \
                         it at the last load step (or by displacement·a(t) with amplitude)"
                    ),
                ));
            }
            (Some(v), None, None) => ObstacleMotion::Velocity(finite("velocity", v)?),
            // The whole displacement at the pseudo-time t = 1, the last load step.
            (None, Some(d), None) if kind == AnalysisKind::Static => {
                ObstacleMotion::reaching(finite("displacement", d)?)
                    .map_err(|e| err("displacement", e.to_string()))?
            }
            (None, Some(_), None) => {
                return Err(err(
                    "displacement",
                    "needs an amplitude in a dynamic scene (a name of [[amplitudes]] or an \
                     inline table)"
                        .into(),
                ));
            }
            (None, None, Some(_)) => {
                return Err(err(
                    "amplitude",
                    "scales nothing: give displacement with it".into(),
                ));
            }
            (None, Some(d), Some(a)) => ObstacleMotion::Amplitude {
                displacement: finite("displacement", d)?,
                amplitude: self.amplitude_of(a, named, &key("amplitude"), span)?,
            },
        };
        Ok(Some(motion))
    }

    /// Whether the scene has `[[obstacles]]`.
    pub fn has_obstacles(&self) -> bool {
        !self.obstacles.is_empty()
    }

    /// The contact of `mesh`'s boundary with the scene's obstacles (`None` without any), with
    /// `[contact]`'s scales (and friction's `slip_distance`, `slip_velocity`) or the library's
    /// defaults for the stiffest material (Pa). A body that
    /// starts inside or on an obstacle is an error naming that obstacle's key and line, the
    /// nodes and their signed distances.
    pub fn contact<C: CellType>(
        &self,
        mesh: &TetMesh<C>,
        youngs_modulus: f64,
    ) -> Result<Option<Contact>> {
        if self.obstacles.is_empty() {
            return Ok(None);
        }
        let mut parameters = ContactParameters::for_mesh(mesh, youngs_modulus)?;
        if let Some(spanned) = &self.spec.contact {
            let c = spanned.get_ref();
            parameters.activation_distance = c
                .activation_distance
                .unwrap_or(parameters.activation_distance);
            parameters.stiffness = c.stiffness.unwrap_or(parameters.stiffness);
            if let Some(f) = c.impact_fraction {
                // The library's check names the allowed range; the scene's error adds the key
                // and its line.
                parameters = parameters.with_impact_fraction(f).map_err(|e| {
                    self.error("contact.impact_fraction", &spanned.span(), e.to_string())
                })?;
            }
        }
        // One obstacle at a time first, so that a body inside one is named by its key and line.
        for (i, (obstacle, spanned)) in self.obstacles.iter().zip(&self.spec.obstacles).enumerate()
        {
            Contact::new(mesh, vec![obstacle.clone()], parameters).map_err(|e| {
                self.error(&format!("obstacles[{i}]"), &spanned.span(), e.to_string())
            })?;
        }
        let mut contact = Contact::new(mesh, self.obstacles.clone(), parameters)?;
        if let Some(spanned) = &self.spec.contact {
            let c = spanned.get_ref();
            if let Some(v) = c.slip_distance {
                contact = contact.with_slip_distance(v)?;
            }
            if let Some(v) = c.slip_velocity {
                contact = contact.with_slip_velocity(v)?;
            }
            if let Some(v) = c.gap_tolerance {
                contact = contact.with_gap_tolerance(v).map_err(|e| {
                    self.error("contact.gap_tolerance", &spanned.span(), e.to_string())
                })?;
            }
        }
        Ok(Some(contact))
    }
}

/// Where a half-space obstacle's tile is drawn (see [`write_obstacles_vtp`]): centred under the
/// body's bounding-box centre, with a side of three times its diagonal (length units), so that
/// the body and its swing stand on it.
pub(crate) fn obstacle_tile<C: CellType>(mesh: &TetMesh<C>) -> (Vector3<f64>, f64) {
    let (low, high) = mesh.bounding_box();
    (0.5 * (low + high), 3.0 * (high - low).norm())
}

#[cfg(test)]
mod tests {
    use tetfem::Error;

    use crate::Scene;

    /// A block over an obstacle given by `obstacle` (its keys), in a scene of analysis `kind`.
    fn scene(kind: &str, obstacle: &str) -> String {
        let analysis = match kind {
            "dynamic" => {
                "type = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 0.01\nduration = 0.1"
            }
            _ => "type = \"static\"",
        };
        format!(
            "[mesh.box]\nmin = [0.0, 0.0, 0.05]\nmax = [0.2, 0.2, 0.25]\ncells = [2, 2, 2]\n\
             [material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.3\ndensity = 1000.0\n\
             [[loads]]\ngravity = [0.0, 0.0, -9.81]\n[analysis]\n{analysis}\n\
             [[obstacles]]\n{obstacle}\nfriction = 0.5\n"
        )
    }

    /// The key a scene's error names, or `None` when it parses.
    fn key_of(text: &str) -> Option<(String, String)> {
        match text.parse::<Scene>() {
            Ok(_) => None,
            Err(Error::Scene { key, message, .. }) => Some((key, message)),
            Err(e) => panic!("{e}"),
        }
    }

    #[test]
    fn spin_keys_are_checked_with_their_key() {
        let ground = "kind = \"half_space\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]";
        // A turntable parses, with the axis point defaulted or given.
        assert_eq!(
            key_of(&scene(
                "dynamic",
                &format!("{ground}\nspin = [0.0, 0.0, 2.0]")
            )),
            None
        );
        let given = format!("{ground}\nspin = [0.0, 0.0, -2.0]\nspin_axis_point = [1.0, 2.0, 0.0]");
        assert_eq!(key_of(&scene("dynamic", &given)), None);
        // A tilted axis would move the plane; a box cannot spin; a sphere off its centre.
        let tilted = format!("{ground}\nspin = [1.0, 0.0, 2.0]");
        let (key, message) = key_of(&scene("dynamic", &tilted)).unwrap();
        assert_eq!(key, "obstacles[0].spin", "{message}");
        assert!(
            message.contains("half_space about an axis along its normal"),
            "{message}"
        );
        let cube =
            "kind = \"box\"\nmin = [0.0, 0.0, -1.0]\nmax = [1.0, 1.0, 0.0]\nspin = [0.0, 0.0, 1.0]";
        assert_eq!(
            key_of(&scene("dynamic", cube)).unwrap().0,
            "obstacles[0].spin"
        );
        let ball =
            "kind = \"sphere\"\ncenter = [0.1, 0.1, -1.0]\nradius = 1.0\nspin = [1.0, 0.0, 0.0]";
        assert_eq!(key_of(&scene("dynamic", ball)), None);
        let off = format!("{ball}\nspin_axis_point = [0.0, 0.0, 0.0]");
        assert_eq!(
            key_of(&scene("dynamic", &off)).unwrap().0,
            "obstacles[0].spin_axis_point"
        );
        // A static solve has no seconds; an axis point without a spin places nothing.
        let spun = format!("{ground}\nspin = [0.0, 0.0, 2.0]");
        assert_eq!(
            key_of(&scene("static", &spun)).unwrap().0,
            "obstacles[0].spin"
        );
        let lone = format!("{ground}\nspin_axis_point = [0.0, 0.0, 0.0]");
        assert_eq!(
            key_of(&scene("dynamic", &lone)).unwrap().0,
            "obstacles[0].spin_axis_point"
        );
    }

    /// A rubber block 2 mm over the ground, falling onto it, with `[contact]` holding `contact`.
    fn landing(contact: &str) -> String {
        format!(
            "[mesh.box]\nmin = [0.0, 0.0, 0.002]\nmax = [0.1, 0.1, 0.102]\ncells = [2, 2, 2]\n\
             [material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.3\ndensity = 1000.0\n\
             [[loads]]\ngravity = [0.0, 0.0, -9.81]\n[analysis]\ntype = \"dynamic\"\n\
             method = \"backward_euler\"\ndt = 1e-3\nduration = 0.04\n\
             [[obstacles]]\nkind = \"half_space\"\npoint = [0.0, 0.0, 0.0]\n\
             normal = [0.0, 0.0, 1.0]\n[contact]\n{contact}\n"
        )
    }

    /// The displacements after each of 40 backward Euler steps of 1 ms (through the landing at
    /// about 20 ms) of the scene `text`'s body, with `parameters` the barrier's scales when
    /// given (the library's own contact of the scene's obstacles) or the scene's contact.
    fn fall(text: &str, parameters: Option<tetfem::contact::ContactParameters>) -> Vec<Vec<f64>> {
        use tetfem::analysis::dynamics::Method;
        use tetfem::analysis::transient::{Flow, StepView, TimeStep, Transient, TransientOptions};
        let scene: Scene = text.parse().unwrap();
        let built = scene.build().unwrap();
        let contact = match parameters {
            Some(p) => tetfem::contact::Contact::new(&built.mesh, scene.obstacles.clone(), p),
            None => scene.contact(&built.mesh, 1e5).map(Option::unwrap),
        };
        let model = tetfem::model::ModelKind::Linear;
        let definition = built.definition(model, Some(contact.unwrap())).unwrap();
        let options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(1e-3));
        let mut run = Transient::new(&definition, options).unwrap();
        let mut states = Vec::new();
        run.run(
            (0, 40),
            &mut |view: &StepView<'_>| -> tetfem::Result<Flow> {
                states.push(view.state.displacement.clone());
                Ok(Flow::Continue)
            },
        )
        .unwrap();
        states
    }

    /// `[contact] impact_fraction` is the library's option: the scene's run and the library's
    /// run with `ContactParameters::with_impact_fraction` on the same mesh and obstacle give
    /// the same bits at every step, and differ from the run without it (the option acts on
    /// this landing).
    #[test]
    fn impact_fraction_is_the_library_option() {
        let text = landing("impact_fraction = 0.25");
        let built = text.parse::<Scene>().unwrap().build().unwrap();
        let parameters = tetfem::contact::ContactParameters::for_mesh(&built.mesh, 1e5)
            .and_then(|p| p.with_impact_fraction(0.25))
            .unwrap();
        let scene_run = fall(&text, None);
        assert_eq!(scene_run, fall(&text, Some(parameters)));
        let default = landing("");
        let without = fall(&default, None);
        assert_ne!(scene_run.last(), without.last());
    }

    /// A fraction outside (0, 1) is refused by the library's check, named by the scene's key
    /// with its value, the allowed range and the `[contact]` table's line.
    #[test]
    fn impact_fraction_out_of_range_is_refused_by_name() {
        for bad in ["0.0", "1.0", "1.5", "-0.25", "nan"] {
            let scene: Scene = landing(&format!("impact_fraction = {bad}"))
                .parse()
                .unwrap();
            let built = scene.build().unwrap();
            match scene.contact(&built.mesh, 1e5) {
                Err(Error::Scene {
                    key, message, line, ..
                }) => {
                    assert_eq!(key, "contact.impact_fraction", "{message}");
                    // The `[contact]` table's line (its keys carry no spans of their own).
                    assert_eq!(line, 20, "{message}");
                    let value: f64 = bad.parse().unwrap();
                    assert!(message.contains(&value.to_string()), "{bad}: {message}");
                    assert!(message.contains("(0, 1)"), "{message}");
                }
                other => panic!("{bad}: {other:?}"),
            }
        }
    }
}
