//! What the robot navigates by: `[navigation] mission_file`, read and checked at start-up with
//! the plan's fence joined to `[navigation.fence]` (a file that cannot be read or followed, or
//! a waypoint outside the fence, refuses the start).

use anyhow::Context;
use dima_core::config::Config;
use dima_core::mission::{parse_plan_file, Navigation};

/// The configured mission, read and parsed, and the fence in force; no mission without
/// `navigation.mission_file`.
pub fn load_navigation(config: &Config) -> anyhow::Result<Navigation> {
    let Some(path) = config.navigation.mission_file() else {
        return Ok(Navigation::from_config(&config.navigation));
    };
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("navigation.mission_file {}: cannot be read", path.display()))?;
    let plan = parse_plan_file(&text)
        .with_context(|| format!("navigation.mission_file {}", path.display()))?;
    Navigation::with_plan(&config.navigation, plan)
        .with_context(|| format!("navigation.mission_file {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_or_missing_mission_file_refuses_and_names_the_file_and_item() {
        let dir = std::env::temp_dir().join(format!("dima-mission-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut config = Config::default();
        assert!(load_navigation(&config).unwrap().mission.is_none());
        config.navigation.mission_file = dir.join("missing.plan");
        let err = format!("{:#}", load_navigation(&config).unwrap_err());
        assert!(err.contains("missing.plan: cannot be read"), "{err}");
        let bad = dir.join("takeoff.plan");
        std::fs::write(
            &bad,
            r#"{"fileType": "Plan", "mission": {"items": [
                {"type": "SimpleItem", "command": 22, "params": [0, 0, 0, null, 48, 11, 10]}]}}"#,
        )
        .unwrap();
        config.navigation.mission_file = bad;
        let err = format!("{:#}", load_navigation(&config).unwrap_err());
        assert!(
            err.contains("mission.items[0]: command 22 (TAKEOFF) is not supported"),
            "{err}"
        );
        let good = dir.join("one.plan");
        std::fs::write(
            &good,
            r#"{"fileType": "Plan", "mission": {"items": [
                {"type": "SimpleItem", "command": 16, "params": [0, 0, 0, null, 48, 11, 0]}]}}"#,
        )
        .unwrap();
        config.navigation.mission_file = good;
        assert_eq!(
            load_navigation(&config)
                .unwrap()
                .mission
                .unwrap()
                .waypoints
                .len(),
            1
        );
        // A plan whose waypoint lies outside its own fence is refused whole.
        let outside = dir.join("outside.plan");
        std::fs::write(
            &outside,
            r#"{"fileType": "Plan",
                "geoFence": {"circles": [{"circle": {"center": [48.001, 11], "radius": 50},
                                          "inclusion": true}]},
                "mission": {"items": [
                {"type": "SimpleItem", "command": 16, "params": [0, 0, 0, null, 48, 11, 0]}]}}"#,
        )
        .unwrap();
        config.navigation.mission_file = outside;
        let err = format!("{:#}", load_navigation(&config).unwrap_err());
        assert!(
            err.contains(
                "outside.plan: mission.items[0]: waypoint (48, 11) lies outside the fence"
            ),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
