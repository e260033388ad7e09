//! The map's origin: where the car stood when the station last sent a revive (the revive
//! point) once that is known, else the first fix.

use std::time::Instant;

/// Which point the origin is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OriginKind {
    /// The first position received.
    FirstFix,
    /// The last position known when the station sent its last revive (or the first after it).
    RevivePoint,
}

/// The map's origin, (latitude, longitude) in degrees, and what it is.
#[derive(Debug, Clone, Default)]
pub struct MapOrigin {
    origin: Option<((f64, f64), OriginKind)>,
    /// The revive the origin was taken for (or is waiting a fix for).
    revive_seen: Option<Instant>,
    waiting_for_fix: bool,
}

impl MapOrigin {
    /// The origin and what it is, once there is one.
    pub fn get(&self) -> Option<((f64, f64), OriginKind)> {
        self.origin
    }

    /// Takes the station's state this frame: when the last revive was sent, the first fix and
    /// the latest fix (with when it arrived). Returns the previous origin when the origin
    /// moved (a new revive point), so a view can keep showing the same ground.
    pub fn update(
        &mut self,
        revive_sent_at: Option<Instant>,
        first_fix: Option<(f64, f64)>,
        latest_fix: Option<(Instant, (f64, f64))>,
    ) -> Option<(f64, f64)> {
        if revive_sent_at.is_some() && revive_sent_at != self.revive_seen {
            self.revive_seen = revive_sent_at;
            self.waiting_for_fix = true;
        }
        let before = self.origin.map(|(o, _)| o);
        if self.waiting_for_fix {
            if let Some((_, fix)) = latest_fix {
                self.origin = Some((fix, OriginKind::RevivePoint));
                self.waiting_for_fix = false;
            }
        }
        if self.origin.is_none() {
            self.origin = first_fix.map(|fix| (fix, OriginKind::FirstFix));
        }
        let after = self.origin.map(|(o, _)| o);
        match before {
            Some(old) if after != Some(old) => Some(old),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn the_origin_is_the_first_fix_until_a_revive_point_is_known() {
        let t0 = Instant::now();
        let at = |s: u64| t0 + Duration::from_secs(s);
        let mut o = MapOrigin::default();
        assert_eq!(o.update(None, None, None), None);
        assert_eq!(o.get(), None);
        let first = (-34.0885, 18.4750);
        o.update(None, Some(first), Some((at(1), first)));
        assert_eq!(o.get(), Some((first, OriginKind::FirstFix)));
        let here = (-34.0886, 18.4751);
        assert_eq!(o.update(None, Some(first), Some((at(2), here))), None);
        assert_eq!(
            o.get(),
            Some((first, OriginKind::FirstFix)),
            "no revive yet"
        );
        // A revive: the car's position then is the origin, and the old one is returned.
        assert_eq!(
            o.update(Some(at(3)), Some(first), Some((at(2), here))),
            Some(first)
        );
        assert_eq!(o.get(), Some((here, OriginKind::RevivePoint)));
        // The car drives off: the origin stays.
        let later = (-34.0890, 18.4760);
        assert_eq!(
            o.update(Some(at(3)), Some(first), Some((at(9), later))),
            None
        );
        assert_eq!(o.get(), Some((here, OriginKind::RevivePoint)));
        // A revive before any fix waits for the first.
        let mut o = MapOrigin::default();
        o.update(Some(at(1)), None, None);
        assert_eq!(o.get(), None);
        o.update(Some(at(1)), Some(first), Some((at(2), first)));
        assert_eq!(o.get(), Some((first, OriginKind::RevivePoint)));
    }
}
