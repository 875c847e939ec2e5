//! QEMU's `netduinoplus2` (STM32F405): the emulated UART the QEMU binaries talk to the host
//! through. Only the QEMU binaries use it; the board's link is USB.

use device::protocol::MAX_FRAME as MAX_FRAME_BYTES;

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

    fn write(addr: usize, value: u32) {
        #[allow(unsafe_code)]
        // SAFETY: an aligned word write to a USART1 register (SR/DR/CR1) of the emulated
        // STM32F405; nothing else in the program owns USART1.
        unsafe {
            core::ptr::write_volatile(addr as *mut u32, value)
        }
    }

    fn read(addr: usize) -> u32 {
        #[allow(unsafe_code)]
        // SAFETY: an aligned word read of a USART1 register of the emulated STM32F405.
        unsafe {
            core::ptr::read_volatile(addr as *const u32)
        }
    }

    /// Enables the transmitter and the receiver (no clock setup: QEMU has no RCC model, and
    /// its USART ignores the baud rate).
    pub fn init() -> Self {
        Self::write(Self::CR1, Self::UE_TE_RE);
        Uart
    }

    /// Sends one frame: COBS, then the delimiter.
    pub fn send_frame(&mut self, frame: &[u8]) {
        let mut encoded = [0u8; cobs::max_encoding_length(MAX_FRAME_BYTES)];
        let frame = frame.get(..MAX_FRAME_BYTES).unwrap_or(frame);
        let n = cobs::encode(frame, &mut encoded);
        for &b in encoded.get(..n).unwrap_or(&[]).iter().chain(&[0u8]) {
            Self::write(Self::DR, u32::from(b));
        }
    }

    /// The next received byte, if one waits.
    pub fn receive(&mut self) -> Option<u8> {
        (Self::read(Self::SR) & Self::RXNE != 0).then(|| Self::read(Self::DR) as u8)
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

    fn write(addr: usize, value: u32) {
        #[allow(unsafe_code)]
        // SAFETY: an aligned word write to a TIM2 register of the emulated STM32F405; nothing
        // else in the program owns TIM2.
        unsafe {
            core::ptr::write_volatile(addr as *mut u32, value)
        }
    }

    fn read(addr: usize) -> u32 {
        #[allow(unsafe_code)]
        // SAFETY: an aligned word read of a TIM2 register of the emulated STM32F405.
        unsafe {
            core::ptr::read_volatile(addr as *const u32)
        }
    }

    /// Starts TIM2 counting microseconds from zero.
    pub fn start() -> Self {
        Self::write(Self::ARR, u32::MAX);
        Self::write(Self::PSC, Self::INPUT_HZ / 1_000_000 - 1);
        // QEMU restarts the count from 0 on a prescaler or counter write.
        Self::write(Self::CNT, 0);
        Self::write(Self::CR1, 1);
        Clock { last: 0, high: 0 }
    }

    /// Microseconds since [`Clock::start`].
    pub fn now_us(&mut self) -> u64 {
        let now = Self::read(Self::CNT);
        if now < self.last {
            self.high += 1 << 32;
        }
        self.last = now;
        self.high | u64::from(now)
    }
}
