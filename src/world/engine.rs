//! The rapier world: chassis and four castors as rigid bodies, obstacles as fixed
//! colliders. The only module that knows how the engine is driven; the rest of the code
//! sees poses, velocities at points, and forces to apply.
//!
//! Top-down: no gravity in the plane; weight enters only through the normal loads in the
//! tyre laws.

use rapier2d_f64::prelude::*;

use crate::model::castor::CastorParams;
use crate::model::chassis::{wrap_angle, LoadedChassis, Pose};
use crate::sensing::bumper::Obstacle;

/// Motion of one castor's contact patch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CastorMotion {
    /// Contact patch, world frame, m.
    pub patch_m: [f64; 2],
    /// Patch velocity over the ground in the castor's frame (rolling, lateral), m/s.
    pub velocity_m_s: [f64; 2],
    /// Castor wheel heading, world frame, rad.
    pub heading_rad: f64,
    /// Swivel angle relative to the body, rad (0: trailing straight behind).
    pub swivel_rad: f64,
}

/// Planar velocity of the chassis.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BodyVelocity {
    /// Velocity of the drive-axle midpoint in the body frame (forward, left), m/s.
    pub axle_m_s: [f64; 2],
    /// Yaw rate, rad/s.
    pub yaw_rate_rad_s: f64,
}

/// The rapier world with the vehicle in it.
pub struct Engine {
    world: PhysicsWorld,
    chassis: RigidBodyHandle,
    castors: [RigidBodyHandle; 4],
    castor: CastorParams,
    /// Heading unwrapped across rapier's (-pi, pi] angle.
    heading_rad: f64,
}

/// A copy of the world for a saved simulation (`Sim`'s `Clone`): every body, collider,
/// joint (with its warm-start impulses), island and contact pair is copied; rapier's
/// pipelines and CCD solver hold only per-step scratch (rapier says so of
/// `PhysicsWorld`'s workspace fields) and start afresh. A copy steps as the original
/// would (`tests/physics.rs` checks it bit for bit).
impl Clone for Engine {
    fn clone(&self) -> Engine {
        let w = &self.world;
        let world = PhysicsWorld {
            gravity: w.gravity,
            integration_parameters: w.integration_parameters,
            physics_pipeline: PhysicsPipeline::new(),
            collision_pipeline: CollisionPipeline::new(),
            islands: w.islands.clone(),
            broad_phase: w.broad_phase.clone(),
            narrow_phase: w.narrow_phase.clone(),
            bodies: w.bodies.clone(),
            colliders: w.colliders.clone(),
            impulse_joints: w.impulse_joints.clone(),
            multibody_joints: w.multibody_joints.clone(),
            soft_bodies: w.soft_bodies.clone(),
            ccd_solver: w.ccd_solver.clone(),
        };
        Engine {
            world,
            chassis: self.chassis,
            castors: self.castors,
            castor: self.castor.clone(),
            heading_rad: self.heading_rad,
        }
    }
}

fn v(p: [f64; 2]) -> Vector {
    Vector::new(p[0], p[1])
}

impl Engine {
    /// Builds the world. `outline` is the body rectangle: (front_m, rear_m, width_m).
    pub fn new(
        chassis: &LoadedChassis,
        castor: CastorParams,
        outline: (f64, f64, f64),
        start: Pose,
        dt_s: f64,
        obstacles: &[Obstacle],
    ) -> Engine {
        let mut world = PhysicsWorld::new();
        world.gravity = Vector::ZERO;
        world.integration_parameters.dt = dt_s;
        // The only constraints are the four castor swivels, and the step is already short
        // (1 ms against swivel dynamics of tens of ms): one solver iteration, warm-started
        // from the last step's joint impulses, holds them as well as rapier's default four
        // (the swivel-alignment and rolling tests check this) at a third of the cost.
        world.integration_parameters.num_solver_iterations = 1;
        world.integration_parameters.warmstart_joints = true;
        let origin = Pose2::new(Vector::new(start.x_m, start.y_m), start.heading_rad);
        let body = RigidBodyBuilder::dynamic()
            .pose(origin)
            .additional_mass_properties(MassProperties::new(
                v(chassis.cg_m),
                chassis.mass_kg,
                chassis.yaw_inertia_kg_m2,
            ))
            .can_sleep(false)
            .build();
        let (front, rear, width) = outline;
        let outline_collider = ColliderBuilder::cuboid(0.5 * (front + rear), 0.5 * width)
            .translation(Vector::new(0.5 * (front - rear), 0.0))
            .density(0.0)
            .build();
        let chassis_h = world.bodies.insert(body);
        world
            .colliders
            .insert_with_parent(outline_collider, chassis_h, &mut world.bodies);
        let mut castors = [chassis_h; 4];
        for (i, p) in chassis.castor_points_m().iter().enumerate() {
            let at = start.to_world(*p);
            let t = castor.trail_m;
            let b = RigidBodyBuilder::dynamic()
                .pose(Pose2::new(
                    v(at),
                    start.heading_rad + castor.initial_angle_rad,
                ))
                .additional_mass_properties(MassProperties::new(
                    Vector::new(-0.5 * t, 0.0),
                    castor.mass_kg,
                    // Fork and wheel as a rod of length 2t about its middle.
                    castor.mass_kg * (2.0 * t).powi(2) / 12.0,
                ))
                .can_sleep(false)
                .build();
            let h = world.bodies.insert(b);
            let joint = RevoluteJointBuilder::new()
                .local_anchor1(v(*p))
                .local_anchor2(Vector::ZERO)
                .contacts_enabled(false)
                .motor_model(MotorModel::ForceBased)
                // A stiff velocity motor towards zero relative rate, capped at the swivel
                // friction: Coulomb friction in the swivel bearing.
                .motor_velocity(0.0, 50.0)
                .motor_max_force(castor.swivel_friction_nm);
            world.impulse_joints.insert(chassis_h, h, joint, true);
            castors[i] = h;
        }
        for o in obstacles {
            let c = ColliderBuilder::new(o.shape.clone())
                .position(o.pose)
                .build();
            world.colliders.insert(c);
        }
        Engine {
            world,
            chassis: chassis_h,
            castors,
            castor,
            heading_rad: start.heading_rad,
        }
    }

    /// Pose of the drive-axle midpoint, heading unwrapped.
    pub fn pose(&self) -> Pose {
        let b = &self.world.bodies[self.chassis];
        let t = b.translation();
        Pose {
            x_m: t.x,
            y_m: t.y,
            heading_rad: self.heading_rad,
        }
    }

    /// Chassis velocity (axle midpoint in the body frame, and yaw rate).
    pub fn body_velocity(&self) -> BodyVelocity {
        let b = &self.world.bodies[self.chassis];
        let pose = self.pose();
        let vel = b.velocity_at_point(b.translation());
        BodyVelocity {
            axle_m_s: pose.unrotate([vel.x, vel.y]),
            yaw_rate_rad_s: b.angvel(),
        }
    }

    /// Velocity over the ground of a body-frame point, in the body frame, m/s.
    pub fn point_velocity_body(&self, p: [f64; 2]) -> [f64; 2] {
        let b = &self.world.bodies[self.chassis];
        let pose = self.pose();
        let w = pose.to_world(p);
        let vel = b.velocity_at_point(v(w));
        pose.unrotate([vel.x, vel.y])
    }

    /// Each castor's patch position, patch velocity and swivel angle.
    pub fn castor_motion(&self) -> [CastorMotion; 4] {
        let chassis_angle = self.world.bodies[self.chassis].rotation().angle();
        self.castors.map(|h| {
            let b = &self.world.bodies[h];
            let pos = b.position();
            let patch = pos.transform_point(Vector::new(-self.castor.trail_m, 0.0));
            let vel = b.velocity_at_point(patch);
            let heading = b.rotation().angle();
            let (s, c) = heading.sin_cos();
            let swivel = wrap_angle(heading - chassis_angle);
            CastorMotion {
                patch_m: [patch.x, patch.y],
                velocity_m_s: [c * vel.x + s * vel.y, -s * vel.x + c * vel.y],
                heading_rad: heading,
                swivel_rad: swivel,
            }
        })
    }

    /// Applies this step's forces (world frame, N) and advances the world by one step.
    /// `wheel_forces`: (body-frame contact point, world force) on the chassis;
    /// `castor_forces`: world force at each castor's contact patch, `motion` the castors'
    /// motion this step began with ([`Engine::castor_motion`]).
    pub fn step(
        &mut self,
        wheel_forces: &[([f64; 2], [f64; 2])],
        castor_forces: &[[f64; 2]; 4],
        motion: &[CastorMotion; 4],
    ) {
        let pose = self.pose();
        let before = self.world.bodies[self.chassis].rotation().angle();
        {
            let b = &mut self.world.bodies[self.chassis];
            // Forces and torques persist in rapier: clear both every step.
            b.reset_forces(false);
            b.reset_torques(false);
            for (p, f) in wheel_forces {
                b.add_force_at_point(v(*f), v(pose.to_world(*p)), false);
            }
        }
        for (i, h) in self.castors.iter().enumerate() {
            let b = &mut self.world.bodies[*h];
            b.reset_forces(false);
            b.reset_torques(false);
            b.add_force_at_point(v(castor_forces[i]), v(motion[i].patch_m), false);
        }
        self.world.step();
        let after = self.world.bodies[self.chassis].rotation().angle();
        self.heading_rad += wrap_angle(after - before);
    }
}
