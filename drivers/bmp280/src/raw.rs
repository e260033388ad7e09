//! Raw 20-bit ADC values and their register bytes (0xF7..=0xFC), the form a sensor board that
//! forwards raw samples to a host carries.

/// Largest 20-bit ADC value.
pub const ADC_MAX: u32 = (1 << 20) - 1;

/// Value of a data register whose measurement was skipped (oversampling `Skip`).
pub const ADC_SKIPPED: u32 = 0x8_0000;

/// Decodes register-order bytes `press_msb, press_lsb, press_xlsb, temp_msb, temp_lsb,
/// temp_xlsb` into `(adc_P, adc_T)`: `msb << 12 | lsb << 4 | xlsb >> 4`. The low nibble of each
/// XLSB byte is unused and ignored.
pub const fn adc_from_bytes(bytes: &[u8; 6]) -> (u32, u32) {
    (
        adc20(bytes[0], bytes[1], bytes[2]),
        adc20(bytes[3], bytes[4], bytes[5]),
    )
}

/// Encodes `(adc_P, adc_T)` into register-order bytes, the inverse of [`adc_from_bytes`]. Bits
/// above the 20th are dropped; each XLSB low nibble is 0, as the device sends it.
pub const fn bytes_from_adc(adc_p: u32, adc_t: u32) -> [u8; 6] {
    let [p0, p1, p2] = bytes20(adc_p);
    let [t0, t1, t2] = bytes20(adc_t);
    [p0, p1, p2, t0, t1, t2]
}

const fn adc20(msb: u8, lsb: u8, xlsb: u8) -> u32 {
    ((msb as u32) << 12) | ((lsb as u32) << 4) | ((xlsb as u32) >> 4)
}

const fn bytes20(adc: u32) -> [u8; 3] {
    let adc = adc & ADC_MAX;
    [
        (adc >> 12) as u8,
        (adc >> 4) as u8,
        ((adc & 0xF) << 4) as u8,
    ]
}

/// One raw sample: the uncompensated 20-bit pressure and temperature ADC values of one burst
/// read, which the calibration turns into physical units (see [`crate::compensation`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawSample {
    /// Pressure ADC value `adc_P`, 0..=0xFFFFF.
    pub adc_p: u32,
    /// Temperature ADC value `adc_T`, 0..=0xFFFFF.
    pub adc_t: u32,
}

impl RawSample {
    /// Largest 20-bit ADC value.
    pub const ADC_MAX: u32 = ADC_MAX;

    /// Value of a data register whose measurement was skipped (oversampling `Skip`).
    pub const ADC_SKIPPED: u32 = ADC_SKIPPED;

    /// A sample from the 6 register bytes 0xF7..=0xFC, in register order (`press_msb`,
    /// `press_lsb`, `press_xlsb`, `temp_msb`, `temp_lsb`, `temp_xlsb`): each value is
    /// `msb << 12 | lsb << 4 | xlsb >> 4`; the low nibble of each XLSB byte is ignored.
    pub const fn from_register_bytes(bytes: &[u8; 6]) -> Self {
        let (adc_p, adc_t) = adc_from_bytes(bytes);
        Self { adc_p, adc_t }
    }

    /// The 6 register bytes 0xF7..=0xFC of this sample, the inverse of
    /// [`RawSample::from_register_bytes`]: bits above the 20th are dropped, each XLSB low nibble
    /// is 0 as the device sends it.
    pub const fn to_register_bytes(&self) -> [u8; 6] {
        bytes_from_adc(self.adc_p, self.adc_t)
    }

    /// True when the pressure measurement was skipped (register value 0x80000).
    pub const fn pressure_skipped(&self) -> bool {
        self.adc_p == ADC_SKIPPED
    }

    /// True when the temperature measurement was skipped (register value 0x80000).
    pub const fn temperature_skipped(&self) -> bool {
        self.adc_t == ADC_SKIPPED
    }

    /// True when both data registers hold their reset value 0x80000: no conversion has ended
    /// since power-on or soft reset (the first one ends the maximum measurement time after
    /// [`Bmp280::configure`](crate::Bmp280::configure) starts normal or forced mode), or both
    /// measurements are configured as skipped.
    ///
    /// A real conversion never sets both registers to 0x80000 at once (with the datasheet
    /// calibration that pair would mean 26.46 °C at 82 044 Pa, and the next conversion differs
    /// in its noise), except with pressure oversampling `Skip`, where the pressure register keeps
    /// 0x80000 and a temperature conversion of exactly 0x80000 is reported as no conversion.
    pub const fn holds_no_conversion(&self) -> bool {
        self.adc_p == ADC_SKIPPED && self.adc_t == ADC_SKIPPED
    }
}
