//! The guest's Debian packages, fetched with `apt-get download` and unpacked (nothing is
//! installed); the kernel among them, and its modules in the order they load.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The guest's modules: USB/IP's virtual host controller, the HID stack up to hidraw, and
/// virtio-9p for the host's file system. Their dependencies are read from the modules
/// themselves (`depends=`) and loaded first.
const MODULES: &[&str] = &[
    "vhci-hcd",
    "usbhid",
    "hid-generic",
    "virtio_pci",
    "9pnet_virtio",
    "9p",
];
/// The Debian packages the guest is made of (fetched, unpacked, not installed); the kernel
/// is `linux-image-amd64`'s dependency of the day.
const GUEST_PACKAGES: &[&str] = &["busybox-static", "usbip"];

/// Fetches the guest's Debian packages into `cache/debs` (once) and unpacks them into
/// `cache/root`; returns that folder.
pub(super) fn fetch_packages(cache: &Path) -> Result<PathBuf, String> {
    let debs = cache.join("debs");
    let unpacked = cache.join("root");
    let image = kernel_package()?;
    let mut wanted: Vec<String> = GUEST_PACKAGES.iter().map(|s| s.to_string()).collect();
    wanted.push(image);
    std::fs::create_dir_all(&debs).map_err(|e| format!("hid: {}: {e}", debs.display()))?;
    let have = |name: &str| -> bool {
        std::fs::read_dir(&debs).is_ok_and(|d| {
            d.flatten().any(|f| {
                f.file_name()
                    .to_string_lossy()
                    .starts_with(&format!("{name}_"))
            })
        })
    };
    let missing: Vec<&str> = wanted
        .iter()
        .map(String::as_str)
        .filter(|p| !have(p))
        .collect();
    if !missing.is_empty() {
        println!(
            "xtask hid: downloading {} (apt-get download, unpacked under {}; nothing is installed)",
            missing.join(", "),
            cache.display()
        );
        let mut args = vec!["download"];
        args.extend(&missing);
        let status = Command::new("apt-get")
            .args(&args)
            .current_dir(&debs)
            .status()
            .map_err(|e| format!("hid: apt-get: {e}"))?;
        if !status.success() {
            return Err(format!(
                "hid: apt-get download {} failed ({status}); the guest needs them",
                missing.join(" ")
            ));
        }
    }
    if !unpacked.join(".done").exists() {
        let _ = std::fs::remove_dir_all(&unpacked);
        for deb in std::fs::read_dir(&debs)
            .map_err(|e| format!("hid: {e}"))?
            .flatten()
        {
            crate::run_in(
                Path::new("."),
                "dpkg-deb",
                &[
                    "-x",
                    &deb.path().to_string_lossy(),
                    &unpacked.to_string_lossy(),
                ],
                &[],
            )?;
        }
        std::fs::write(unpacked.join(".done"), b"").map_err(|e| format!("hid: {e}"))?;
    }
    Ok(unpacked)
}

/// The kernel package `linux-image-amd64` depends on today (`linux-image-6.1.0-N-amd64`).
fn kernel_package() -> Result<String, String> {
    let out = crate::output("apt-cache", &["depends", "linux-image-amd64"])?;
    out.lines()
        .filter_map(|l| l.trim().strip_prefix("Depends: "))
        .find(|p| p.starts_with("linux-image-"))
        .map(str::to_owned)
        .ok_or_else(|| format!("hid: no kernel among linux-image-amd64's dependencies:\n{out}"))
}

pub(super) fn find_kernel(unpacked: &Path) -> Result<PathBuf, String> {
    std::fs::read_dir(unpacked.join("boot"))
        .map_err(|e| format!("hid: the kernel package's boot/: {e}"))?
        .flatten()
        .map(|f| f.path())
        .find(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("vmlinuz-"))
        })
        .ok_or_else(|| "hid: no vmlinuz in the kernel package".into())
}

/// The modules folder (`lib/modules/VERSION`) of the unpacked kernel.
fn modules_dir(unpacked: &Path) -> Result<PathBuf, String> {
    let base = unpacked.join("lib").join("modules");
    std::fs::read_dir(&base)
        .map_err(|e| format!("hid: {}: {e}", base.display()))?
        .flatten()
        .map(|f| f.path())
        .next()
        .ok_or_else(|| "hid: no modules in the kernel package".into())
}

/// Every `.ko` under `dir`, by module name (dashes as underscores, as the kernel names them).
fn index_modules(dir: &Path, out: &mut Vec<(String, PathBuf)>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            index_modules(&p, out);
        } else if let Some(stem) = p.file_name().and_then(|n| n.to_str()?.strip_suffix(".ko")) {
            out.push((stem.replace('-', "_"), p.clone()));
        }
    }
}

/// A module's dependencies, from its `.modinfo` section's `depends=` string (an entry of
/// that NUL-separated list: the key at the start of one).
fn depends(ko: &[u8]) -> Vec<String> {
    let key = b"depends=";
    ko.windows(key.len())
        .enumerate()
        .position(|(at, w)| w == key && (at == 0 || ko[at - 1] == 0))
        .map(|at| {
            let rest = &ko[at + key.len()..];
            let end = rest.iter().position(|&b| b == 0).unwrap_or(rest.len());
            String::from_utf8_lossy(&rest[..end])
                .split(',')
                .filter(|s| !s.is_empty())
                .map(|s| s.replace('-', "_"))
                .collect()
        })
        .unwrap_or_default()
}

/// [`MODULES`] and their dependencies, each after what it depends on: `(name, bytes)`.
pub(super) fn modules_in_order(unpacked: &Path) -> Result<Vec<(String, Vec<u8>)>, String> {
    let mut index = Vec::new();
    index_modules(&modules_dir(unpacked)?, &mut index);
    let mut order: Vec<(String, Vec<u8>)> = Vec::new();
    fn visit(
        name: &str,
        index: &[(String, PathBuf)],
        order: &mut Vec<(String, Vec<u8>)>,
        depth: usize,
    ) -> Result<(), String> {
        if order.iter().any(|(n, _)| n == name) {
            return Ok(());
        }
        if depth > 32 {
            return Err(format!("hid: module dependencies loop at {name}"));
        }
        let path = index
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, p)| p)
            .ok_or_else(|| format!("hid: the kernel package has no module {name}"))?;
        let bytes = std::fs::read(path).map_err(|e| format!("hid: {}: {e}", path.display()))?;
        for d in depends(&bytes) {
            visit(&d, index, order, depth + 1)?;
        }
        order.push((name.to_string(), bytes));
        Ok(())
    }
    for m in MODULES {
        visit(&m.replace('-', "_"), &index, &mut order, 0)?;
    }
    Ok(order)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `.modinfo` entries are NUL-separated `key=value` strings; `depends=` lists the
    /// modules to load first, comma-separated, with the kernel's dashes as underscores.
    #[test]
    fn depends_reads_the_modinfo_entry() {
        let ko =
            b"\x7fELF\0\0license=GPL\0xdepends=nothing\0depends=usbcore,hid-generic\0intree=Y\0";
        assert_eq!(depends(ko), ["usbcore", "hid_generic"]);
        assert!(depends(b"\0depends=\0name=x\0").is_empty());
        assert!(depends(b"\0xdepends=usbcore\0").is_empty());
        assert!(depends(b"no modinfo at all").is_empty());
    }
}
