//! The application: the realtime loop, the telemetry and logger threads, and their wiring.

pub mod mission;
pub mod record;
pub mod rt_loop;

pub use record::{CycleRecord, Snapshot};
pub use rt_loop::{BusyFault, LoopEnds, LoopParams, RealtimeLoop};
pub mod run;

pub use run::{
    hardware_devices, install_signal_handlers, run, Devices, Observer, RunOptions, RunSummary,
};
