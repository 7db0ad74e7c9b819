//! From a scene to library options and a model: the preconditioner rule, the solver and simulation options, the memory estimate, and the build.

use super::*;

impl Scene {
    /// The model options of the scene.
    pub(super) fn model_options(&self) -> ModelOptions {
        ModelOptions {
            damping: match self.model.damping {
                DampingScene::Projected => SpringDamping::Projected,
                DampingScene::Incorrect => SpringDamping::Incorrect,
                DampingScene::None => SpringDamping::None,
            },
            air_friction: self.model.air_friction,
            gravity: self.model.gravity,
            clamp_stiffness: self.model.clamp_stiffness,
            ..ModelOptions::default()
        }
    }

    /// The scene's preconditioner with its settings: `auto` resolved by the
    /// model's size, SSOR's and MIC(0)'s relaxations from `omega` and
    /// `mic_omega`, the multigrid's options from `[solver.amg]` (the
    /// library's defaults without the table).
    pub fn preconditioner(&self) -> PreconditionerOptions {
        let s = &self.solver;
        // An unknown (overflowing) count keeps MIC(0), as before; the memory cap refuses it.
        let particles = self.particle_count().0.unwrap_or(0);
        let auto = PrecondKind::auto_for_blocks(usize::try_from(particles).unwrap_or(usize::MAX));
        let kind = match s.preconditioner.unwrap_or(auto) {
            PrecondKind::Mic0 { .. } => PrecondKind::Mic0 { omega: s.mic_omega },
            PrecondKind::Ssor { .. } => PrecondKind::Ssor { omega: s.omega },
            other => other,
        };
        PreconditionerOptions {
            kind,
            amg: s.amg.as_ref().map(AmgScene::options).unwrap_or_default(),
            ..Default::default()
        }
    }

    /// The scene's `integrator.method`, with the settings the scene gives
    /// the method: `integrator.max_order` for the variable-order BDF.
    pub fn method(&self) -> Method {
        let mut method = self.integrator.method.clone();
        if let Method::VariableBdf(config) = &mut method {
            config.max_order = self.integrator.max_order;
        }
        method
    }

    /// The integrator, Newton and PCG options of the scene.
    pub fn simulation_options(&self) -> SimulationOptions {
        let s = &self.solver;
        let forcing = match s.forcing {
            ForcingScene::Constant(eta) => ForcingTerm::Constant(eta),
            ForcingScene::Ew1 => ForcingTerm::EisenstatWalker1,
            ForcingScene::Ew2 => ForcingTerm::EW2_DEFAULT,
        };
        let mut solver: SolverOptions = SimulationOptions::drape_solver();
        // "auto" needs the model: `build` replaces this placeholder.
        solver.h = self.integrator.h.value().unwrap_or(solver.h);
        solver.rtol = self.integrator.rtol;
        solver.atol = self.integrator.atol.into();
        solver.step.h_max = self.integrator.h_max;
        solver.max_steps = self.integrator.max_steps;
        solver.step.control = match self.integrator.control {
            ControlScene::Error => StepControl::error_based(),
            ControlScene::Newton => StepControl::newton_iterations(),
        };
        solver.newton.method = match s.newton {
            NewtonScene::Exact => NewtonMethod::Exact,
            NewtonScene::Inexact => NewtonMethod::Inexact(forcing),
            NewtonScene::Simplified => NewtonMethod::Simplified,
            NewtonScene::InexactSimplified => NewtonMethod::InexactSimplified(forcing),
        };
        solver.newton.rtol = s.newton_rtol;
        solver.newton.max_iter = s.max_newton;
        solver.newton.linear_rtol = match s.newton {
            NewtonScene::Exact | NewtonScene::Simplified => s.cg_rtol,
            _ => solver.newton.linear_rtol,
        };
        solver.linear.max_iter = Some(s.max_cg);
        solver.warm_start = s.warm_start;
        solver.filter_matrix = s.filter_matrix.unwrap_or_else(|| {
            self.contact.self_collision
                || self
                    .colliders
                    .iter()
                    .any(|c| matches!(c, ColliderScene::Mesh { .. }))
        });
        solver.linear.preconditioner = self.preconditioner();
        // The exact stiffness Jacobian may be indefinite where springs are
        // compressed: PCG then truncates (Newton-CG) instead of failing.
        solver.linear.negative_curvature = if self.model.clamp_stiffness {
            NegativeCurvature::Error
        } else {
            NegativeCurvature::Truncate
        };
        SimulationOptions {
            method: self.method(),
            solver,
            filter: self.filter.as_ref().map(|f| FilterOptions {
                kernel: match f.kernel {
                    KernelScene::Exponential => Kernel::Exponential { lambda: f.lambda },
                    KernelScene::Gaussian => Kernel::Gaussian { lambda: f.lambda },
                },
                form: match f.form {
                    FormScene::Symmetric => Form::Symmetric,
                    FormScene::Plain => Form::Plain,
                },
                rings: f.rings,
                current_distances: f.distances == DistancesScene::Current,
                ..Default::default()
            }),
            filter_coupling: match self.filter.as_ref().map(|f| f.coupling) {
                Some(CouplingScene::Velocity) => FilterCoupling::VelocityOnly,
                Some(CouplingScene::Positions) => FilterCoupling::CorrectPositions,
                Some(CouplingScene::Increment) | None => FilterCoupling::Increment,
            },
            energy_budget: self.integrator.energy_budget,
            ..SimulationOptions::default()
        }
    }

    /// The cloth of a `[cloth]` scene as builder parameters (with the
    /// scene's `[model]` options), or `None` for other scenes.
    pub fn cloth_params(&self) -> Option<ClothParams> {
        let c = self.cloth.as_ref()?;
        let axis_v = match c.plane {
            PlaneScene::Horizontal => [0.0, 1.0, 0.0],
            PlaneScene::Vertical => [0.0, 0.0, 1.0],
        };
        // About +x: (y, z) -> (y cos - z sin, y sin + z cos).
        let axis_v = if c.tilt == 0.0 {
            axis_v
        } else {
            let (s, co) = c.tilt.to_radians().sin_cos();
            [
                0.0,
                axis_v[1] * co - axis_v[2] * s,
                axis_v[1] * s + axis_v[2] * co,
            ]
        };
        Some(ClothParams {
            nu: c.n,
            nv: c.n,
            width: c.size,
            height: c.size,
            origin: c.origin,
            axis_u: [1.0, 0.0, 0.0],
            axis_v,
            total_mass: c.mass,
            structural: SpringMaterial::new(c.stiffness, c.damping),
            shear: SpringMaterial::new(c.stiffness, c.damping),
            bend: SpringMaterial::new(c.bend_stiffness.unwrap_or(c.stiffness / 10.0), c.damping),
            pins: match c.pins {
                PinScene::TwoCorners => ClothPins::TwoCorners,
                PinScene::FourCorners => ClothPins::FourCorners,
                PinScene::Edge => ClothPins::Edge,
                PinScene::None => ClothPins::None,
            },
            options: self.model_options(),
            ..Default::default()
        })
    }

    /// The number of particles the scene's model has, and the key that sets
    /// it (a program's model table counts as one particle, its name the
    /// key); `None` for a count that overflows 64 bits.
    pub fn particle_count(&self) -> (Option<u64>, &'static str) {
        if let Some(c) = &self.cloth {
            ((c.n as u64).checked_mul(c.n as u64), "cloth.n")
        } else if let Some(r) = &self.rope {
            (Some(r.n as u64), "rope.n")
        } else if let Some(j) = &self.jelly {
            let [a, b, c] = j.n.map(|k| k as u64);
            (a.checked_mul(b).and_then(|ab| ab.checked_mul(c)), "jelly.n")
        } else if self.particle.is_some() {
            (Some(1), "particle")
        } else if let Some(m) = &self.mesh {
            (Some(obj_vertex_count(&self.resolve(&m.path))), "mesh.path")
        } else {
            (Some(1), self.program_model.unwrap_or("model"))
        }
    }

    /// A path of the scene (a mesh file) as it is read: a relative path
    /// starts at the scene file's folder.
    pub fn resolve(&self, path: &Path) -> std::path::PathBuf {
        match &self.base {
            Some(base) if path.is_relative() => base.join(path),
            _ => path.to_path_buf(),
        }
    }

    /// An upper estimate of the memory the scene's model and its implicit
    /// solver need, in bytes, and the key that sets the size: about
    /// 1 KiB per particle (state, forces, solver vectors) and 0.5 KiB per
    /// spring (its Jacobian blocks in `df/dx`, `df/dv`, the system matrix
    /// and its preconditioner), plus, with a `[filter]`, 32 bytes per
    /// neighbour of every particle's `rings`-ring neighbourhood (at most
    /// `(2 rings + 1)^d` particles on a `d`-dimensional lattice, and never
    /// more than the model has; the key is then `filter.rings` if the
    /// neighbourhoods are the larger part). `None` for a size that
    /// overflows 64 bits.
    pub fn memory_estimate(&self) -> (Option<u64>, &'static str) {
        let (bytes, key) = self.model_memory_estimate();
        let Some(filter) = &self.filter else {
            return (bytes, key);
        };
        const PER_NEIGHBOUR: u64 = 32;
        let dimension = if self.cloth.is_some() {
            2
        } else if self.jelly.is_some() {
            3
        } else {
            1
        };
        let (particles, _) = self.particle_count();
        let neighbours = particles.and_then(|p| {
            let side = (filter.rings as u64).checked_mul(2)?.checked_add(1)?;
            let ring = side.checked_pow(dimension).unwrap_or(u64::MAX).min(p);
            p.checked_mul(ring)?.checked_mul(PER_NEIGHBOUR)
        });
        match (bytes, neighbours) {
            (Some(b), Some(f)) if f > b => (b.checked_add(f), "filter.rings"),
            (Some(b), Some(f)) => (b.checked_add(f), key),
            (Some(_), None) => (None, "filter.rings"),
            (None, _) => (None, key),
        }
    }

    /// [`memory_estimate`](Self::memory_estimate) without the filter.
    pub(super) fn model_memory_estimate(&self) -> (Option<u64>, &'static str) {
        const PER_PARTICLE: u64 = 1 << 10;
        const PER_SPRING: u64 = 1 << 9;
        // Springs per particle: cloth 6 (structural, shear, bend), rope 2,
        // 3D lattice at most 13 (half of the 26 neighbours).
        let springs_per = if self.cloth.is_some() || self.mesh.is_some() {
            6
        } else if self.rope.is_some() {
            2
        } else if self.jelly.is_some() {
            13
        } else {
            1
        };
        let (particles, key) = self.particle_count();
        let bytes = particles.and_then(|p| {
            p.checked_mul(PER_PARTICLE)?
                .checked_add(p.checked_mul(springs_per)?.checked_mul(PER_SPRING)?)
        });
        (bytes, key)
    }

    /// The largest scene file [`from_file`](Self::from_file) reads: 16 MiB.
    pub const MAX_FILE_BYTES: u64 = 16 << 20;

    /// The memory cap of [`build`](Self::build): 8 GiB.
    pub const DEFAULT_MAX_BYTES: u64 = 8 << 30;

    /// Builds the model and the simulation the scene describes, refusing a
    /// scene larger than [`DEFAULT_MAX_BYTES`](Self::DEFAULT_MAX_BYTES).
    ///
    /// # Errors
    /// As [`build_within`](Self::build_within).
    pub fn build(&self) -> Result<Simulation, HookeanError> {
        self.build_within(Self::DEFAULT_MAX_BYTES)
    }

    /// Builds the model and the simulation the scene describes, refusing
    /// (before anything is allocated) a scene whose
    /// [`memory_estimate`](Self::memory_estimate) exceeds `max_bytes`.
    ///
    /// # Errors
    /// [`HookeanError::TooLarge`] naming the key that sets the size; the
    /// builders' and the integrator's typed errors.
    pub fn build_within(&self, max_bytes: u64) -> Result<Simulation, HookeanError> {
        let (bytes, key) = self.memory_estimate();
        if bytes.is_none_or(|b| b > max_bytes) {
            return Err(HookeanError::TooLarge {
                key,
                bytes,
                max_bytes,
            });
        }
        if let Some(table) = self.program_model {
            return Err(HookeanError::InvalidOption {
                name: table.into(),
                message: format!(
                    "[{table}] is a model table of the program that read the scene, not a mass-spring model"
                ),
            });
        }
        let options = self.model_options();
        let in_table = |table: &str| {
            let table = table.to_string();
            move |e: hookean_massspring::MassSpringError| HookeanError::Build {
                table: table.clone(),
                message: e.to_string(),
            }
        };
        let (mut model, state) = if let Some(params) = self.cloth_params() {
            hookean_massspring::cloth(&params).map_err(in_table("cloth"))?
        } else if let Some(r) = &self.rope {
            hookean_massspring::rope(&RopeParams {
                n: r.n,
                length: r.length,
                total_mass: r.mass,
                material: SpringMaterial::new(r.stiffness, r.damping),
                direction: r.direction,
                pin_start: r.pin_start,
                pin_end: r.pin_end,
                options,
                ..RopeParams::default()
            })
            .map_err(in_table("rope"))?
        } else if let Some(j) = &self.jelly {
            let m = SpringMaterial::new(j.stiffness, j.damping);
            hookean_massspring::jelly_block(&BlockParams {
                n: j.n,
                spacing: j.spacing,
                origin: j.origin,
                total_mass: j.mass,
                edge: m,
                face: m,
                body: m,
                options,
                ..Default::default()
            })
            .map_err(in_table("jelly"))?
        } else if let Some(m) = &self.mesh {
            let (obj, _) =
                hookean_massspring::read_surface(self.resolve(&m.path), m.scale, m.offset)
                    .map_err(in_table("mesh"))?;
            let bend = m.bend_stiffness.unwrap_or(m.stiffness / 10.0);
            let (mut model, state) = hookean_massspring::from_mesh(
                &obj,
                &MeshParams {
                    total_mass: m.mass,
                    edge: SpringMaterial::new(m.stiffness, m.damping),
                    bend: (bend > 0.0).then(|| SpringMaterial::new(bend, m.damping)),
                    options,
                    ..Default::default()
                },
            )
            .map_err(in_table("mesh"))?;
            let pins = pins::select_vertices("mesh", "pins", &m.pins, m.pin_box, &state.x)?;
            for p in pins {
                let at = [state.x[3 * p], state.x[3 * p + 1], state.x[3 * p + 2]];
                model.pin(p, at).map_err(in_table("mesh"))?;
            }
            (model, state)
        } else {
            let (mut model, state) =
                hookean_massspring::tutorial_example3().map_err(in_table("particle"))?;
            if self.model.damping != DampingScene::Projected
                || self.model.air_friction != 0.0
                || self.model.gravity != d_gravity()
            {
                model.set_options(options).map_err(in_table("model"))?;
            }
            (model, state)
        };
        for (i, c) in self.colliders.iter().enumerate() {
            let collider = in_table(&format!("collider {}", i + 1));
            let friction = |mu_s: f64, mu_k: Option<f64>| {
                Friction::new(mu_s, mu_k.unwrap_or(mu_s)).map_err(&collider)
            };
            model.add_collider(match c {
                ColliderScene::Plane {
                    point,
                    normal,
                    margin,
                    static_friction,
                    kinetic_friction,
                } => Collider::plane(*point, *normal, *margin)
                    .map_err(&collider)?
                    .with_friction(friction(*static_friction, *kinetic_friction)?),
                ColliderScene::Sphere {
                    center,
                    radius,
                    margin,
                    static_friction,
                    kinetic_friction,
                } => Collider::sphere(*center, *radius, *margin)
                    .map_err(&collider)?
                    .with_friction(friction(*static_friction, *kinetic_friction)?),
                ColliderScene::Mesh {
                    path,
                    scale,
                    offset,
                    thickness,
                    static_friction,
                    kinetic_friction,
                    velocity,
                    angular_velocity,
                    pivot,
                    keys,
                    interpolation,
                    frames,
                    frame_interval,
                } => {
                    let table = format!("collider {}", i + 1);
                    let build = |message: String| HookeanError::Build {
                        table: table.clone(),
                        message,
                    };
                    let rigid = *velocity != [0.0; 3] || *angular_velocity != [0.0; 3];
                    if [rigid, !keys.is_empty(), !frames.is_empty()]
                        .iter()
                        .filter(|&&b| b)
                        .count()
                        > 1
                    {
                        return Err(build(
                            "give one motion: velocity / angular_velocity, keys, or frames".into(),
                        ));
                    }
                    crate::range::Range::POSITIVE
                        .check(*frame_interval)
                        .map_err(|e| build(format!("frame_interval: {e}")))?;
                    let (_, surface) =
                        hookean_massspring::read_surface(self.resolve(path), *scale, *offset)
                            .map_err(&collider)?;
                    let centre = surface.aabb().center();
                    let pivot = pivot.unwrap_or([centre.x, centre.y, centre.z]);
                    let mesh = if !frames.is_empty() {
                        let mut poses = Vec::with_capacity(frames.len() + 1);
                        poses.push(surface);
                        for (k, f) in frames.iter().enumerate() {
                            let file = self.resolve(f);
                            let (_, pose) =
                                hookean_massspring::read_surface(&file, *scale, *offset)
                                    .map_err(&collider)?;
                            if pose.vertices().len() != poses[0].vertices().len()
                                || pose.triangles() != poses[0].triangles()
                            {
                                return Err(build(format!(
                                    "frames[{k}] ({}): {} vertices and {} faces, path ({}) has {} and {}: every frame must have the vertices and faces of path, in the same order",
                                    file.display(),
                                    pose.vertices().len(),
                                    pose.triangles().len(),
                                    self.resolve(path).display(),
                                    poses[0].vertices().len(),
                                    poses[0].triangles().len()
                                )));
                            }
                            poses.push(pose);
                        }
                        MeshCollider::sequence(poses, *frame_interval, *thickness)
                            .map_err(&collider)?
                    } else if !keys.is_empty() {
                        let path = pins::keyframed_path(keys, *interpolation, pivot)
                            .map_err(&build)?;
                        MeshCollider::new(surface, *thickness)
                            .map_err(&collider)?
                            .with_path(path)
                    } else {
                        let motion = RigidMotion {
                            velocity: *velocity,
                            angular_velocity: *angular_velocity,
                            pivot,
                        };
                        MeshCollider::new(surface, *thickness)
                            .and_then(|m| m.with_motion(motion))
                            .map_err(&collider)?
                    };
                    Collider::mesh(mesh)
                        .with_friction(friction(*static_friction, *kinetic_friction)?)
                }
            });
        }
        for (i, group) in self.pins.iter().enumerate() {
            group.add_to(i + 1, &mut model, &state.x)?;
        }
        if self.contact.self_collision {
            model
                .set_self_collision(Some(SelfCollision {
                    thickness: self.contact.self_thickness,
                    stiffness: self.contact.self_stiffness,
                    ..Default::default()
                }))
                .map_err(in_table("contact"))?;
            model
                .check_self_thickness(&state.x)
                .map_err(in_table("contact"))?;
        }
        if let Some(w) = &self.wind {
            model.set_wind(Some(w.wind())).map_err(in_table("wind"))?;
        }
        // A start inside a collider: its put-back would turn the depth into
        // spring energy the scene never had (docs/CONTACT.md).
        let inside = model.particles_inside(&state.x);
        if let Some((c, &count)) = inside.iter().enumerate().find(|(_, n)| **n > 0) {
            return Err(HookeanError::Build {
                table: format!("collider {}", c + 1),
                message: format!(
                    "{count} of the model's {} particles start inside it (deeper than round-off); every particle must start outside each collider or on its surface: move the model or the collider",
                    model.n_particles()
                ),
            });
        }
        let mut options = self.simulation_options();
        if self.integrator.h == StepScene::Auto {
            let filter = options
                .filter
                .as_ref()
                .map(|f| (f, options.filter_coupling));
            options.solver.h = hookean_filter::auto_step(
                &model,
                &state.x,
                &options.method,
                filter,
                self.integrator.h_safety,
            )
            .map_err(|e| HookeanError::InvalidOption {
                name: "integrator.h".into(),
                message: format!("\"auto\": {e}"),
            })?
            .h;
        }
        Simulation::new(model, state, options).map_err(|e| match e {
            HookeanError::InvalidOption { name, message } if name == "filter" => {
                HookeanError::Build {
                    table: name,
                    message,
                }
            }
            e => e,
        })
    }
}
