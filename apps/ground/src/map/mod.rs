//! The map panel's pure parts, each with its own tests:
//! - [`mercator`]: Web Mercator latitude/longitude ↔ slippy-map tile coordinates, and the
//!   tile zoom whose pixels match the view;
//! - [`view`]: the local metre grid on the screen (zoom, pan, follow), the tiles a view needs,
//!   the car marker and the heading arrow as screen geometry;
//! - [`scale`]: the scale bar's round length;
//! - [`tiles`]: offline tiles from a `z/x/y.png` directory, decoded, and a bounded cache;
//! - [`origin`]: the first fix, or the revive point once known;
//! - [`plan`]: the mission and the fence of a plan file or of the robot's log, in metres;
//! - [`setpoint`]: the heading setpoint the map draws.

pub mod mercator;
pub mod origin;
pub mod plan;
pub mod scale;
pub mod setpoint;
pub mod tiles;
pub mod view;
