//! The shared simulated world: the vehicle model on the simulation clock, advanced on demand by
//! the device threads (never by the application's threads).

use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

use crate::model::{Inputs, PulseMap, Vehicle, VehicleParams, VehicleState, DIMA_PULSE_MAPS};

/// The vehicle and the simulation clock.
#[derive(Debug)]
pub struct World {
    start: Instant,
    vehicle: Mutex<Vehicle>,
    maps: [PulseMap; 3],
}

impl World {
    /// A car at rest heading `heading_deg`, clock starting now.
    pub fn new(params: VehicleParams, heading_deg: f64) -> World {
        World {
            start: Instant::now(),
            vehicle: Mutex::new(Vehicle::new(params, heading_deg)),
            maps: DIMA_PULSE_MAPS,
        }
    }

    /// Seconds since the start.
    pub fn now_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// The instant of simulation time `t_s`.
    pub fn instant_at(&self, t_s: f64) -> Instant {
        self.start + Duration::from_secs_f64(t_s.max(0.0))
    }

    fn vehicle(&self) -> MutexGuard<'_, Vehicle> {
        // A panicked device thread must not take the others down with it.
        self.vehicle.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The state now.
    pub fn state(&self) -> VehicleState {
        let t = self.now_s();
        let mut v = self.vehicle();
        v.advance_to(t);
        *v.state()
    }

    /// Applies the pulse widths (µs; 0 = no pulses) of throttle, steering and tail from now.
    pub fn set_pulses(&self, pulses_us: [f64; 3]) {
        let t = self.now_s();
        let mut v = self.vehicle();
        v.advance_to(t);
        v.set_inputs(Inputs {
            throttle: self.maps[0].fraction(pulses_us[0]),
            steering: self.maps[1].fraction(pulses_us[1]),
            tail: self.maps[2].fraction(pulses_us[2]),
        });
    }
}
