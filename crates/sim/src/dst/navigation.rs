//! The navigation a run's robot is configured with: on every even seed a waypoint mission
//! (a closed loop around the car's start point) and a geofence (around the mission, sometimes
//! tighter than it), both drawn from the seed; odd seeds run without either.
//!
//! The loop has 3 to 6 corners on a circle of 12 to 40 m radius around the start point (sides
//! of about 20 to 70 m), at a random rotation, and ends back at its first corner. The fence is
//! one of: an inclusion circle around the start point (the loop's radius plus a margin of -8
//! to +30 m: a negative margin puts part of the loop outside), an inclusion polygon (the
//! loop's corners scaled by 0.8 to 1.8), a largest distance from the revive point alone (8 m
//! to the loop's radius plus 40 m), or a wide circle together with a largest distance of 10
//! to 40 m. One even seed in ten has the mission without a fence, one in ten the fence
//! without a mission.

use crate::board::{BoardConfig, EARTH_RADIUS_M};
use crate::rng::SimRng;
use dima_core::config::{FenceCircle, FenceConfig};
pub use dima_core::mission::Navigation;
use dima_core::mission::{Mission, Waypoint};

/// Whether `seed` runs with a mission and a fence (every even seed).
pub fn seed_has_navigation(seed: u64) -> bool {
    seed.is_multiple_of(2)
}

/// A point `north_m`, `east_m` from the car's start, `[lat_deg, lon_deg]`, as the simulated
/// receiver converts the car's position.
pub fn start_offset(north_m: f64, east_m: f64) -> [f64; 2] {
    let c = BoardConfig::default();
    let lat0 = c.start_lat_deg.to_radians();
    [
        c.start_lat_deg + (north_m / EARTH_RADIUS_M).to_degrees(),
        c.start_lon_deg + (east_m / (EARTH_RADIUS_M * lat0.cos())).to_degrees(),
    ]
}

/// The navigation of `seed`, drawn from `rng` (`None` on odd seeds): the robot's
/// `dima_core::mission::Navigation`, the same record a trace writes into its log.
pub fn for_seed(seed: u64, rng: SimRng) -> Option<Navigation> {
    seed_has_navigation(seed).then(|| draw(rng))
}

/// A mission and a fence drawn from `rng`.
pub fn draw(mut rng: SimRng) -> Navigation {
    let corners = 3 + rng.below(4) as usize;
    let radius_m = 12.0 + rng.uniform() * 28.0;
    let phase = rng.uniform() * std::f64::consts::TAU;
    let loop_ne: Vec<[f64; 2]> = (0..corners)
        .map(|i| {
            let a = phase + i as f64 * std::f64::consts::TAU / corners as f64;
            [radius_m * a.cos(), radius_m * a.sin()]
        })
        .collect();
    let waypoints: Vec<Waypoint> = loop_ne
        .iter()
        .chain(loop_ne.first())
        .enumerate()
        .map(|(item, &[n, e])| {
            let [lat_deg, lon_deg] = start_offset(n, e);
            Waypoint {
                lat_deg,
                lon_deg,
                acceptance_m: None,
                speed_m_s: None,
                item,
            }
        })
        .collect();
    let [lat_deg, lon_deg] = start_offset(0.0, 0.0);
    let fence = match rng.below(4) {
        0 => FenceConfig {
            circles: vec![FenceCircle {
                lat_deg,
                lon_deg,
                radius_m: radius_m - 8.0 + rng.uniform() * 38.0,
            }],
            ..FenceConfig::default()
        },
        1 => {
            let scale = 0.8 + rng.uniform();
            FenceConfig {
                polygons: vec![loop_ne
                    .iter()
                    .map(|&[n, e]| start_offset(n * scale, e * scale))
                    .collect()],
                ..FenceConfig::default()
            }
        }
        2 => FenceConfig {
            max_distance_m: Some(8.0 + rng.uniform() * (radius_m + 32.0)),
            ..FenceConfig::default()
        },
        _ => FenceConfig {
            max_distance_m: Some(10.0 + rng.uniform() * 30.0),
            circles: vec![FenceCircle {
                lat_deg,
                lon_deg,
                radius_m: radius_m + 20.0 + rng.uniform() * 40.0,
            }],
            ..FenceConfig::default()
        },
    };
    let mission = Some(Mission { waypoints });
    match rng.below(10) {
        0 => Navigation {
            mission,
            fence: FenceConfig::default(),
        },
        1 => Navigation {
            mission: None,
            fence,
        },
        _ => Navigation { mission, fence },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_core::geo::{distance_m, LatLon};

    #[test]
    fn odd_seeds_run_without_even_seeds_with_a_valid_loop_and_fence() {
        assert_eq!(for_seed(3, SimRng::new(3)), None);
        let start = LatLon::new(
            BoardConfig::default().start_lat_deg,
            BoardConfig::default().start_lon_deg,
        );
        let (mut missions, mut fences) = (0, 0);
        for seed in (2..200).step_by(2) {
            let nav = for_seed(seed, SimRng::new(seed)).expect("an even seed");
            let mut config = dima_core::config::Config::default();
            config.navigation.fence = nav.fence.clone();
            config.validate().expect("a valid fence");
            fences += usize::from(config.navigation.fence != FenceConfig::default());
            if let Some(m) = &nav.mission {
                missions += 1;
                assert!((4..=7).contains(&m.waypoints.len()));
                assert_eq!(
                    m.waypoints.first(),
                    m.waypoints
                        .last()
                        .map(|w| Waypoint { item: 0, ..*w })
                        .as_ref()
                );
                for w in &m.waypoints {
                    let d = distance_m(start, LatLon::new(w.lat_deg, w.lon_deg));
                    assert!((11.9..=40.1).contains(&d), "{d} m from the start");
                }
            }
            assert!(nav.mission.is_some() || config.navigation.fence != FenceConfig::default());
        }
        assert!(
            missions > 80 && fences > 80,
            "{missions} missions, {fences} fences"
        );
    }
}
