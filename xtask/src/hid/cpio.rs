//! cpio archives in the "newc" format, as the kernel unpacks its initramfs.

/// A cpio archive in the "newc" format the kernel unpacks as its initramfs.
#[derive(Default)]
pub(super) struct Cpio {
    out: Vec<u8>,
    ino: u32,
}

impl Cpio {
    fn entry(&mut self, name: &str, mode: u32, data: &[u8]) {
        self.ino += 1;
        let header = format!(
            "070701{:08X}{:08X}{:08X}{:08X}{:08X}{:08X}{:08X}{:08X}{:08X}{:08X}{:08X}{:08X}{:08X}",
            self.ino,
            mode,
            0,
            0,
            1,
            0,
            data.len(),
            0,
            0,
            0,
            0,
            name.len() + 1,
            0
        );
        self.out.extend_from_slice(header.as_bytes());
        self.out.extend_from_slice(name.as_bytes());
        self.out.push(0);
        self.pad();
        self.out.extend_from_slice(data);
        self.pad();
    }

    fn pad(&mut self) {
        while !self.out.len().is_multiple_of(4) {
            self.out.push(0);
        }
    }

    pub(super) fn dir(&mut self, name: &str) {
        self.entry(name, 0o040_755, &[]);
    }

    pub(super) fn file(&mut self, name: &str, perm: u32, data: &[u8]) {
        self.entry(name, 0o100_000 | perm, data);
    }

    pub(super) fn symlink(&mut self, name: &str, to: &str) {
        self.entry(name, 0o120_777, to.as_bytes());
    }

    pub(super) fn finish(mut self) -> Vec<u8> {
        self.entry("TRAILER!!!", 0, &[]);
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The "newc" format as the kernel's buffer-format document gives it: "070701", then
    /// thirteen 8-digit hexadecimal fields (ino, mode, uid, gid, nlink, mtime, filesize,
    /// devmajor, devminor, rdevmajor, rdevminor, namesize with its NUL, check), the name and
    /// its NUL padded to a multiple of four from the archive's start, the data padded the
    /// same, and a last entry named TRAILER!!!. Written out by hand for one file "a" of
    /// "xy", mode 0644.
    #[test]
    fn cpio_entries_are_newc_as_specified() {
        let mut cpio = Cpio::default();
        cpio.file("a", 0o644, b"xy");
        let out = cpio.finish();
        let mut expected = String::from("070701");
        for field in [1, 0o100_644, 0, 0, 1, 0, 2, 0, 0, 0, 0, 2, 0] {
            expected.push_str(&format!("{field:08X}"));
        }
        expected.push_str("a\0xy\0\0");
        expected.push_str("070701");
        for field in [2, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 11, 0] {
            expected.push_str(&format!("{field:08X}"));
        }
        expected.push_str("TRAILER!!!\0\0\0\0");
        assert_eq!(String::from_utf8_lossy(&out), expected);
        assert_eq!(out.len(), 240);
        assert_eq!(&expected[6..22], "00000001000081A4");
    }
}
