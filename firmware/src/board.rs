//! Board constants: clocks, bus speeds, pins and timing. Change the hardware here, in one place.

/// The board's crystal (HSE), in hertz.
#[cfg_attr(feature = "qemu", allow(dead_code))]
pub const HSE_HZ: u32 = 8_000_000;

/// System clock from the PLL, in hertz (the STM32F405/407 maximum).
#[cfg_attr(feature = "qemu", allow(dead_code))]
pub const SYSCLK_HZ: u32 = 168_000_000;

/// Core clock of QEMU's `netduinoplus2` machine, in hertz: fixed, since QEMU models no RCC.
#[cfg(feature = "qemu")]
pub const QEMU_CORE_HZ: u32 = 168_000_000;

/// Clock of the general-purpose timers in QEMU's STM32F405 model, in hertz: fixed at 1 GHz,
/// whatever the prescalers say.
#[cfg(feature = "qemu")]
pub const QEMU_TIMER_HZ: u32 = 1_000_000_000;

/// The internal oscillator the `qemu` build runs on (and the HAL computes timer settings for).
#[cfg(feature = "qemu")]
pub const HSI_HZ: u32 = 16_000_000;

/// Link to the host (USART3, 8 data bits, no parity, 2 stop bits), in baud. The host must use
/// the same rate. At 460 800 baud a 132-byte packet takes 3.15 ms.
pub const LINK_BAUD: u32 = 460_800;

/// GNSS receiver link (USART1), in baud: the NEO-M8T's configured rate.
pub const GNSS_BAUD: u32 = 115_200;

/// Sensor sampling rate (accelerometer and gyroscope; one packet published per tick), in hertz.
pub const SAMPLE_RATE_HZ: u32 = 1_000;

/// Rate of the monotonic clock behind uptime and the status LED, in hertz (1 tick = 1 ms, so
/// uptime in milliseconds wraps after 49.7 days like the info frame's field).
pub const MONO_HZ: u32 = 1_000;

/// Independent watchdog timeout, in milliseconds. The sampling tick feeds it; if sampling stops
/// for this long, the board resets.
pub const WATCHDOG_MS: u32 = 100;

/// GNSS receive DMA buffer length, in bytes (a NAV-PVT frame is 100 bytes).
pub const GNSS_DMA_LEN: usize = 128;

/// Firmware version reported in the info frame: major, minor, patch from Cargo.toml.
pub const FIRMWARE_VERSION: [u8; 3] = [
    parse_u8(env!("CARGO_PKG_VERSION_MAJOR")),
    parse_u8(env!("CARGO_PKG_VERSION_MINOR")),
    parse_u8(env!("CARGO_PKG_VERSION_PATCH")),
];

/// Parses a decimal version component at compile time (saturating at 255).
const fn parse_u8(text: &str) -> u8 {
    let bytes = text.as_bytes();
    let mut value: u32 = 0;
    let mut i = 0;
    while i < bytes.len() {
        value = value * 10 + (bytes[i] - b'0') as u32;
        i += 1;
    }
    if value > 255 {
        255
    } else {
        value as u8
    }
}
