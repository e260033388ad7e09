//! Keys from egui, for [`crate::keys`]: Space always (and no widget ever sees it, so a
//! focused button cannot be "pressed" by the kill key); the driving keys unless a text field
//! has focus (then they are typing), and never passed on to widgets (a focused slider does
//! not move with the arrows while they drive).

use eframe::egui::{self, Event, Key};

use crate::keys::KeysHeld;

/// Keys the keyboard contract uses besides Space.
const DRIVING_KEYS: [Key; 12] = [
    Key::ArrowUp,
    Key::ArrowDown,
    Key::ArrowLeft,
    Key::ArrowRight,
    Key::W,
    Key::S,
    Key::A,
    Key::D,
    Key::Q,
    Key::E,
    Key::R,
    Key::Space,
];

/// Reads this frame's keys and removes them from what widgets see.
pub fn read_keys(ctx: &egui::Context) -> KeysHeld {
    let typing = ctx.text_edit_focused();
    ctx.input_mut(|i| {
        let kill_pressed = i.events.iter().any(|e| {
            matches!(
                e,
                Event::Key {
                    key: Key::Space,
                    pressed: true,
                    ..
                }
            )
        });
        let down =
            |i: &egui::InputState, keys: &[Key]| !typing && keys.iter().any(|k| i.key_down(*k));
        let held = KeysHeld {
            throttle_up: down(i, &[Key::ArrowUp, Key::W]),
            throttle_down: down(i, &[Key::ArrowDown, Key::S]),
            steer_right: down(i, &[Key::ArrowRight, Key::D]),
            steer_left: down(i, &[Key::ArrowLeft, Key::A]),
            tail_right: down(i, &[Key::E]),
            tail_left: down(i, &[Key::Q]),
            revive: down(i, &[Key::R]),
            kill_pressed,
        };
        i.events.retain(|e| match e {
            Event::Key {
                key: Key::Space, ..
            } => false,
            Event::Text(t) if t == " " => false,
            Event::Key { key, .. } if !typing => !DRIVING_KEYS.contains(key),
            Event::Text(_) => typing,
            _ => true,
        });
        held
    })
}
