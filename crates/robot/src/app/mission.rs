//! The waypoint mission the robot follows in AUTO: `[navigation] mission_file`, read and
//! checked at start-up (a file that cannot be read or followed refuses the start).

use anyhow::Context;
use dima_core::config::Config;
use dima_core::mission::{parse_plan, Mission};

/// The configured mission, read and parsed; `None` without `navigation.mission_file`.
pub fn load_mission(config: &Config) -> anyhow::Result<Option<Mission>> {
    let Some(path) = config.navigation.mission_file() else {
        return Ok(None);
    };
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("navigation.mission_file {}: cannot be read", path.display()))?;
    let mission =
        parse_plan(&text).with_context(|| format!("navigation.mission_file {}", path.display()))?;
    Ok(Some(mission))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_or_missing_mission_file_refuses_and_names_the_file_and_item() {
        let dir = std::env::temp_dir().join(format!("dima-mission-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut config = Config::default();
        assert!(load_mission(&config).unwrap().is_none());
        config.navigation.mission_file = dir.join("missing.plan");
        let err = format!("{:#}", load_mission(&config).unwrap_err());
        assert!(err.contains("missing.plan: cannot be read"), "{err}");
        let bad = dir.join("takeoff.plan");
        std::fs::write(
            &bad,
            r#"{"fileType": "Plan", "mission": {"items": [
                {"type": "SimpleItem", "command": 22, "params": [0, 0, 0, null, 48, 11, 10]}]}}"#,
        )
        .unwrap();
        config.navigation.mission_file = bad;
        let err = format!("{:#}", load_mission(&config).unwrap_err());
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
        assert_eq!(load_mission(&config).unwrap().unwrap().waypoints.len(), 1);
        std::fs::remove_dir_all(&dir).ok();
    }
}
