//! The sensor bus clock: which SPI1 prescaler the HAL picks for a requested rate, and the
//! rate the firmware asks for so that the bus never runs faster than the sensors allow.
//!
//! SPI has no CRC: a bit flipped by a bus clocked out of specification goes into the packet
//! under a valid packet CRC. The BMX055 and the BMP280 both allow at most
//! [`SENSOR_SPI_MAX_HZ`].
//!
//! The HAL (`stm32f4xx-hal` 0.23, `Spi::pre_init`) turns a requested rate into SPI_CR1's
//! baud-rate bits from the integer ratio `pclk / requested`: 1-2 → /2, 3-5 → /4, 6-11 → /8,
//! 12-23 → /16, 24-47 → /32, 48-95 → /64, 96-191 → /128, larger → /256. It rounds to the
//! nearest divider, so it can pick one that runs faster than asked (8 MHz asked of an
//! 84 MHz APB2 gives /8 = 10.5 MHz). [`hal_divider`] is that rule; [`sensor_request_hz`] is
//! the rate the firmware asks for.

/// The fastest SPI clock the BMX055 and the BMP280 accept, in hertz.
pub const SENSOR_SPI_MAX_HZ: u32 = 10_000_000;

/// APB2 (SPI1's clock) on the board: the 168 MHz system clock halved, the most APB2 allows.
pub const BOARD_PCLK2_HZ: u32 = 84_000_000;

/// The divider (2, 4, ..., 256) the HAL programs into SPI_CR1 for `requested_hz` from an
/// APB clock of `pclk_hz` (see the module documentation). A request of 0 Hz or above the
/// APB clock gets the fastest divider, as a ratio of 1 does in the HAL.
#[must_use]
pub const fn hal_divider(pclk_hz: u32, requested_hz: u32) -> u32 {
    let ratio = match pclk_hz.checked_div(requested_hz) {
        Some(ratio) => ratio,
        None => 1,
    };
    match ratio {
        0..=2 => 2,
        3..=5 => 4,
        6..=11 => 8,
        12..=23 => 16,
        24..=47 => 32,
        48..=95 => 64,
        96..=191 => 128,
        _ => 256,
    }
}

/// SPI_CR1's baud-rate field BR\[2:0\] for `divider` (2 → 0b000, ..., 256 → 0b111;
/// RM0090 28.5.1).
#[must_use]
pub const fn br_bits(divider: u32) -> u8 {
    (divider.trailing_zeros() as u8).saturating_sub(1) & 0b111
}

/// The divider SPI_CR1's baud-rate bits `br` select (the inverse of [`br_bits`]).
#[must_use]
pub const fn divider_of_br(br: u8) -> u32 {
    2 << (br & 0b111)
}

/// The SPI clock that results from asking for `requested_hz` from an APB clock of
/// `pclk_hz`, in hertz.
#[must_use]
pub const fn hal_spi_hz(pclk_hz: u32, requested_hz: u32) -> u32 {
    pclk_hz / hal_divider(pclk_hz, requested_hz)
}

/// The rate to ask the HAL for on SPI1 when APB2 runs at `pclk_hz`: the fastest clock the
/// prescaler can make from `pclk_hz` that is not above [`SENSOR_SPI_MAX_HZ`], given as the
/// exact quotient `pclk_hz / divider` so that the HAL's rounding lands on that divider (or, if
/// `pclk_hz` does not divide evenly, on a slower one). At the board's 84 MHz: 5.25 MHz (/16).
#[must_use]
pub const fn sensor_request_hz(pclk_hz: u32) -> u32 {
    let mut divider = 2;
    while divider < 256 && pclk_hz / divider > SENSOR_SPI_MAX_HZ {
        divider *= 2;
    }
    let request = pclk_hz / divider;
    // The HAL divides by the request: never ask for 0 Hz.
    if request == 0 {
        1
    } else {
        request
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_board_sensor_bus_runs_at_most_at_the_sensors_limit() {
        let requested = sensor_request_hz(BOARD_PCLK2_HZ);
        let divider = hal_divider(BOARD_PCLK2_HZ, requested);
        let spi_hz = BOARD_PCLK2_HZ / divider;
        assert!(
            spi_hz <= SENSOR_SPI_MAX_HZ,
            "SPI1 at {spi_hz} Hz (APB2 {BOARD_PCLK2_HZ} Hz / {divider}, BR {:#05b}) is above the \
             sensors' {SENSOR_SPI_MAX_HZ} Hz",
            br_bits(divider)
        );
        // The fastest the prescaler allows: /8 would be 10.5 MHz.
        assert_eq!((divider, br_bits(divider), spi_hz), (16, 0b011, 5_250_000));
    }

    #[test]
    fn the_hal_rounds_eight_megahertz_of_84_to_ten_and_a_half() {
        // What the release binary wrote (SPI1_CR1 = 0x317, BR = 0b010) before the fix.
        assert_eq!(hal_divider(84_000_000, 8_000_000), 8);
        assert_eq!(hal_spi_hz(84_000_000, 8_000_000), 10_500_000);
        assert_eq!((0x317 >> 3) & 0b111, u32::from(br_bits(8)));
    }

    #[test]
    fn every_apb_clock_gets_the_fastest_divider_within_the_limit() {
        for pclk_hz in (100_000..=100_000_000)
            .step_by(12_345)
            .chain([16_000_000, 42_000_000])
        {
            let requested = sensor_request_hz(pclk_hz);
            let divider = hal_divider(pclk_hz, requested);
            assert!(
                pclk_hz / divider <= SENSOR_SPI_MAX_HZ,
                "APB {pclk_hz} Hz: asked {requested} Hz, got /{divider}"
            );
            // Half the divider would be too fast (or there is no smaller one).
            assert!(
                divider == 2 || pclk_hz / (divider / 2) > SENSOR_SPI_MAX_HZ,
                "APB {pclk_hz} Hz: /{divider} is slower than needed"
            );
        }
    }

    #[test]
    fn br_bits_and_dividers_are_inverse() {
        for br in 0..8u8 {
            assert_eq!(br_bits(divider_of_br(br)), br);
        }
        assert_eq!(divider_of_br(0), 2);
        assert_eq!(divider_of_br(7), 256);
    }

    #[test]
    fn the_hal_rule_covers_every_band_edge() {
        let pclk = 96_000_000;
        for (ratio, divider) in [(1, 2), (2, 2), (3, 4), (5, 4), (6, 8), (11, 8), (12, 16)]
            .into_iter()
            .chain([
                (23, 16),
                (24, 32),
                (47, 32),
                (48, 64),
                (95, 64),
                (96, 128),
                (191, 128),
            ])
            .chain([(192, 256), (1000, 256)])
        {
            assert_eq!(hal_divider(pclk, pclk / ratio), divider, "ratio {ratio}");
        }
        assert_eq!(hal_divider(pclk, 0), 2);
    }
}
