//! QEMU's `netduinoplus2` (STM32F405): the emulated UART the QEMU binaries talk to the host
//! through. Only the QEMU binaries use it; the board's link is USB.

use device::kinematics::KinematicsError;
use device::simulator::SimulatedPantograph;
use nurbs::Vec2;
use protocol::MAX_FRAME as MAX_FRAME_BYTES;

use crate::board::Board;

/// An aligned word write to `addr`, one of the emulated STM32F405's peripheral registers
/// named below (USART1, TIM2).
fn write(addr: usize, value: u32) {
    #[allow(unsafe_code)]
    // SAFETY: `addr` is one of this module's register constants: an aligned, memory-mapped
    // register of USART1 or TIM2, which nothing else in the program owns.
    unsafe {
        core::ptr::write_volatile(addr as *mut u32, value)
    }
}

/// An aligned word read of `addr`, as [`write`].
fn read(addr: usize) -> u32 {
    #[allow(unsafe_code)]
    // SAFETY: as `write`: an aligned, memory-mapped register of USART1 or TIM2.
    unsafe {
        core::ptr::read_volatile(addr as *const u32)
    }
}

/// USART1 of the STM32F405 (QEMU's `stm32f2xx_usart`, the first `-serial`): the link, each
/// frame COBS-encoded and followed by a `0x00` delimiter, exactly as the host's serial and TCP
/// links read it. QEMU sends a byte written to DR at once (TXE is never observed clear) and
/// holds received bytes until DR is read, so neither direction needs waiting or a buffer.
#[derive(Debug)]
pub struct Uart;

impl Uart {
    const BASE: usize = 0x4001_1000;
    const SR: usize = Self::BASE;
    const DR: usize = Self::BASE + 0x04;
    const CR1: usize = Self::BASE + 0x0C;
    /// SR: a received byte waits in DR.
    const RXNE: u32 = 1 << 5;
    /// CR1: USART enable, transmitter enable, receiver enable. The STM32F4's UE is bit 13;
    /// QEMU 7.2's model tests bit 14 (`USART_CR1_UE` in its `stm32f2xx_usart.h`) before it
    /// accepts a received byte, so both are set (bit 14 is reserved on the chip).
    const UE_TE_RE: u32 = (1 << 14) | (1 << 13) | (1 << 3) | (1 << 2);

    /// Enables the transmitter and the receiver (no clock setup: QEMU has no RCC model, and
    /// its USART ignores the baud rate).
    pub fn init() -> Self {
        write(Self::CR1, Self::UE_TE_RE);
        Uart
    }

    /// Sends one frame: COBS, then the delimiter.
    pub fn send_frame(&mut self, frame: &[u8]) {
        let mut encoded = [0u8; cobs::max_encoding_length(MAX_FRAME_BYTES)];
        let frame = frame.get(..MAX_FRAME_BYTES).unwrap_or(frame);
        let n = cobs::encode(frame, &mut encoded);
        for &b in encoded.get(..n).unwrap_or(&[]).iter().chain(&[0u8]) {
            write(Self::DR, u32::from(b));
        }
    }

    /// The next received byte, if one waits.
    pub fn receive(&mut self) -> Option<u8> {
        (read(Self::SR) & Self::RXNE != 0).then(|| read(Self::DR) as u8)
    }
}

/// TIM2 of the STM32F405 (QEMU's `stm32f2xx_timer`), free running as the monotonic clock in
/// microseconds: 32 bits, extended to 64 by counting its wraps (read it at least once every
/// 71 minutes). QEMU clocks the SoC's timers at 1 GHz (its `clock-frequency`), so the
/// prescaler divides by 1000; on the chip the prescaler would divide the APB1 timer clock.
#[derive(Debug)]
pub struct Clock {
    last: u32,
    high: u64,
}

impl Clock {
    const BASE: usize = 0x4000_0000;
    const CR1: usize = Self::BASE;
    const CNT: usize = Self::BASE + 0x24;
    const PSC: usize = Self::BASE + 0x28;
    const ARR: usize = Self::BASE + 0x2C;
    /// The timer's input clock in QEMU (Hz).
    const INPUT_HZ: u32 = 1_000_000_000;

    /// Starts TIM2 counting microseconds from zero.
    pub fn start() -> Self {
        write(Self::ARR, u32::MAX);
        write(Self::PSC, Self::INPUT_HZ / 1_000_000 - 1);
        // QEMU restarts the count from 0 on a prescaler or counter write.
        write(Self::CNT, 0);
        write(Self::CR1, 1);
        Clock { last: 0, high: 0 }
    }

    /// Microseconds since [`Clock::start`].
    pub fn now_us(&mut self) -> u64 {
        let now = read(Self::CNT);
        if now < self.last {
            self.high += 1 << 32;
        }
        self.last = now;
        self.high | u64::from(now)
    }
}

/// The emulated board both QEMU binaries run the app on: the simulated pantograph as the plant
/// (its encoders; its motors, whose currents a disabled driver cuts), a clock the binary sets,
/// and the UART as the link.
#[derive(Debug)]
pub struct SimulatedBoard {
    /// The plant.
    pub arm: SimulatedPantograph,
    /// The clock the app reads (µs), set by the binary before each tick.
    pub now_us: u64,
    /// Frames sent on the link.
    pub frames_sent: u32,
    currents_a: [f32; 2],
    driver_enabled: bool,
    uart: Uart,
}

impl SimulatedBoard {
    /// The board with `arm` as its plant and the UART enabled.
    pub fn new(arm: SimulatedPantograph) -> Self {
        SimulatedBoard {
            arm,
            now_us: 0,
            frames_sent: 0,
            currents_a: [0.0; 2],
            driver_enabled: false,
            uart: Uart::init(),
        }
    }

    /// Moves the plant one period `period_s` under the last commanded currents (none while
    /// the driver is disabled) and the virtual hand pulling towards `hand_target`.
    pub fn step_plant(&mut self, hand_target: Vec2, period_s: f32) -> Result<(), KinematicsError> {
        let currents = if self.driver_enabled {
            self.currents_a
        } else {
            [0.0; 2]
        };
        self.arm.step(currents, hand_target, period_s)
    }
}

impl Board for SimulatedBoard {
    fn encoder_counts(&mut self) -> [i32; 2] {
        self.arm.encoder_counts()
    }

    fn set_motor_currents(&mut self, currents_a: [f32; 2]) {
        self.currents_a = currents_a;
    }

    fn set_driver_enabled(&mut self, enabled: bool) {
        self.driver_enabled = enabled;
    }

    fn now_us(&mut self) -> u64 {
        self.now_us
    }

    fn link_send(&mut self, frame: &[u8]) {
        self.uart.send_frame(frame);
        self.frames_sent = self.frames_sent.wrapping_add(1);
    }

    fn link_receive(&mut self, buf: &mut [u8]) -> usize {
        let mut n = 0;
        for slot in buf.iter_mut() {
            match self.uart.receive() {
                Some(b) => *slot = b,
                None => break,
            }
            n += 1;
        }
        n
    }
}
