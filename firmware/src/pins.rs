//! The board's pins as data: the Adafruit Feather STM32F405 Express's
//! header (what each pin is connected to on the board), the signals the
//! firmware puts on it, the timers it takes, and the alternate functions
//! those need. `bsp/board.rs` is where the pins are set up; a host test
//! (`tests/tests/pins.rs`) checks that it uses exactly [`USED`] and
//! [`TIMERS`], that every used pin is on the header and carries its
//! function, and that no two signals share a pin or a timer; the book's
//! pin map and wiring diagram are drawn from here.
//!
//! Sources: the Feather's Eagle schematic and board
//! (adafruit/Adafruit-Feather-STM32F405-Express-PCB, commit f10cfb4,
//! `Adafruit Feather STM32F405 Express.sch`: each header net followed to
//! the LQFP64 pad; the `.brd` agrees net for net), with MicroPython's
//! `boards/ADAFRUIT_F405_EXPRESS/pins.csv` as a second reading; the
//! alternate functions from the STM32F405 datasheet's table (DS8626,
//! "Alternate function mapping"), as MicroPython's `stm32f405_af.csv` and
//! stm32duino's `PeripheralPins.c` transcribe it (they agree).

/// A pin on the Feather's headers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HeaderPin {
    /// The silkscreen's label.
    pub label: &'static str,
    /// The MCU's port pin (e.g. "PA4"), or the net for power pins.
    pub pin: &'static str,
    /// The LQFP64 package pin (0: not an MCU pin).
    pub lqfp: u8,
    /// What else the net goes to on the board ("" for nothing).
    pub also: &'static str,
}

const fn h(label: &'static str, pin: &'static str, lqfp: u8, also: &'static str) -> HeaderPin {
    HeaderPin {
        label,
        pin,
        lqfp,
        also,
    }
}

/// Every header pin of the Feather (the 16-pin row, then the 12-pin row).
pub const FEATHER: [HeaderPin; 28] = [
    h("RST", "NRST", 7, "reset button"),
    h("3V", "+3V3", 0, "3.3 V rail"),
    h("AREF", "+3V3", 0, "3.3 V rail (tied)"),
    h("GND", "GND", 0, ""),
    h("A0", "PA4", 20, ""),
    h("A1", "PA5", 21, ""),
    h("A2", "PA6", 22, ""),
    h("A3", "PA7", 23, ""),
    h("A4", "PC4", 24, ""),
    h("A5", "PC5", 25, ""),
    h("SCK", "PB13", 34, ""),
    h("MO", "PB15", 36, ""),
    h("MI", "PB14", 35, ""),
    h("RX", "PB11", 30, "100 kOhm pull-up"),
    h("TX", "PB10", 29, ""),
    h("B0", "BOOT0", 60, "100 kOhm pull-down"),
    h("BAT", "VBAT", 0, "battery connector, charger"),
    h("EN", "EN", 0, "regulator enable"),
    h("USB", "VBUS", 0, "USB-C VBUS"),
    h("D13", "PC1", 9, "red LED"),
    h("D12", "PC2", 10, ""),
    h("D11", "PC3", 11, ""),
    h("D10", "PB9", 62, ""),
    h("D9", "PB8", 61, ""),
    h("D6", "PC6", 37, ""),
    h("D5", "PC7", 38, ""),
    h("SCL", "PB6", 58, "STEMMA QT, 10 kOhm pull-up"),
    h("SDA", "PB7", 59, "STEMMA QT, 10 kOhm pull-up"),
];

/// MCU pins on no net of the Feather at all (a signal there reaches
/// nothing): by the schematic and the board file.
pub const UNCONNECTED: [&str; 7] = ["PC13", "PA0", "PA1", "PA2", "PB0", "PB1", "PA8"];

/// A signal the firmware puts on a pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Use {
    /// What it is.
    pub signal: &'static str,
    /// The port pin.
    pub pin: &'static str,
    /// The peripheral function (e.g. "SPI1_SCK", "TIM10_CH1", "GPIO out").
    pub function: &'static str,
    /// The alternate function number (`None`: GPIO or EXTI).
    pub af: Option<u8>,
    /// Where it goes on the rig.
    pub to: &'static str,
}

const fn u(
    signal: &'static str,
    pin: &'static str,
    function: &'static str,
    af: Option<u8>,
    to: &'static str,
) -> Use {
    Use {
        signal,
        pin,
        function,
        af,
        to,
    }
}

/// Every signal the firmware uses (`bsp/board.rs`).
pub const USED: [Use; 11] = [
    u("IMU SCK", "PA5", "SPI1_SCK", Some(5), "IMU SCLK"),
    u("IMU MISO", "PA6", "SPI1_MISO", Some(5), "IMU SDO"),
    u("IMU MOSI", "PA7", "SPI1_MOSI", Some(5), "IMU SDI"),
    u("IMU chip select", "PA4", "GPIO out", None, "IMU CS"),
    u("IMU data-ready", "PC4", "EXTI4", None, "IMU INT1"),
    u("encoder A", "PB6", "TIM4_CH1", Some(2), "encoder A"),
    u("encoder B", "PB7", "TIM4_CH2", Some(2), "encoder B"),
    u("motor PWM", "PB8", "TIM10_CH1", Some(3), "driver PWM"),
    u("motor direction", "PC6", "GPIO out", None, "driver DIR"),
    u("telemetry TX", "PB10", "USART3_TX", Some(7), "USB-UART RX"),
    u("telemetry RX", "PB11", "USART3_RX", Some(7), "USB-UART TX"),
];

/// Every timer the firmware takes, and for what: each one thing.
pub const TIMERS: [(&str, &str); 4] = [
    ("TIM3", "the link task's 100 Hz"),
    ("TIM4", "the encoder's quadrature counter"),
    ("TIM5", "the 1 MHz clock"),
    ("TIM10", "the motor's PWM"),
];

/// The alternate functions of the pins used, by the datasheet: (pin, AF,
/// function).
pub const ALTERNATE: [(&str, u8, &str); 14] = [
    ("PA5", 5, "SPI1_SCK"),
    ("PA6", 5, "SPI1_MISO"),
    ("PA7", 5, "SPI1_MOSI"),
    ("PB6", 2, "TIM4_CH1"),
    ("PB7", 2, "TIM4_CH2"),
    ("PB8", 2, "TIM4_CH3"),
    ("PB8", 3, "TIM10_CH1"),
    ("PB10", 7, "USART3_TX"),
    ("PB11", 7, "USART3_RX"),
    ("PC6", 2, "TIM3_CH1"),
    ("PC6", 3, "TIM8_CH1"),
    ("PA8", 1, "TIM1_CH1"),
    ("PB9", 3, "TIM11_CH1"),
    ("PC7", 3, "TIM8_CH2"),
];

/// The header label of port pin `pin` (`None`: not on the header).
pub fn label(pin: &str) -> Option<&'static str> {
    FEATHER.iter().find(|p| p.pin == pin).map(|p| p.label)
}
