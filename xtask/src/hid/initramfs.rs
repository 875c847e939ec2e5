//! The guest's initramfs: its `/init` (the mounts, the chroot of the host's folders, the
//! check of what the chroot holds, the check itself), written from [`GuestInit`], in a cpio
//! archive with busybox and the modules.

use std::path::{Path, PathBuf};

use super::cpio::Cpio;
use super::packages::modules_in_order;

/// The guest's chroot: a tmpfs of the guest's own, outside the host's file system (mounted
/// read-only at `/host`). Its `/tmp` and `/run` are the guest's scratch space; every other
/// folder of the host's `/` is bound into it at its own name, so nothing of the host's is
/// mounted over and a checkout anywhere (under `/tmp` too) stays visible.
const GUEST_ROOT: &str = "/guest-root";
/// The host's top-level folders the guest does not take from the host: its own writable
/// scratch (`/tmp`, and `/run` where `usbip attach` records its ports in `/var/run/vhci_hcd`
/// and libudev looks for the host's device database) and its own kernel interfaces.
const GUEST_SCRATCH: &[(&str, &str)] = &[("tmp", "1777"), ("run", "755")];
/// The guest's own `/proc`, `/sys` and `/dev`, bound into the chroot.
const GUEST_KERNEL_FS: &[&str] = &["proc", "sys", "dev"];

/// An entry of the host's `/`, as the guest's chroot repeats it.
#[derive(Clone, Debug, PartialEq, Eq)]
enum RootEntry {
    /// A folder: bound from the host, unless it is one of the guest's own.
    Dir(String),
    /// A symbolic link (`bin -> usr/bin`): the same link.
    Symlink(String, String),
}

impl RootEntry {
    fn name(&self) -> &str {
        match self {
            Self::Dir(name) | Self::Symlink(name, _) => name,
        }
    }
}

/// What the guest's `/init` is written from: the host's paths the guest must see as the
/// host does (absolute, without symbolic links: [`GuestInit::from_host`] canonicalizes
/// them), the modules to load in order, and the host's `/`.
#[derive(Clone, Debug)]
pub(super) struct GuestInit {
    modules: Vec<String>,
    /// The checkout: the session reads its scenes.
    checkout: PathBuf,
    /// The target folder: the binaries and the unpacked guest packages are under it.
    target: PathBuf,
    /// `CARGO_HOME` when it exists.
    cargo_home: Option<PathBuf>,
    xtask: PathBuf,
    viewer: PathBuf,
    usbip: PathBuf,
    host_root: Vec<RootEntry>,
}

impl GuestInit {
    /// The paths as this host has them (canonicalized, each error naming its path) and the
    /// entries of its `/`.
    pub(super) fn from_host(
        root: &Path,
        target: &Path,
        unpacked: &Path,
        xtask: &Path,
        viewer: &Path,
    ) -> Result<Self, String> {
        let modules = modules_in_order(unpacked)?
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        let usbip = unpacked.join("usr").join("sbin").join("usbip");
        if !usbip.exists() {
            return Err(format!("hid: the usbip package has no {}", usbip.display()));
        }
        let abs = |p: &Path| -> Result<PathBuf, String> {
            std::fs::canonicalize(p).map_err(|e| format!("hid: {}: {e}", p.display()))
        };
        let cargo_home = std::env::var_os("CARGO_HOME")
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")))
            .and_then(|p| std::fs::canonicalize(p).ok());
        let mut host_root = Vec::new();
        for e in std::fs::read_dir("/")
            .map_err(|e| format!("hid: the host's /: {e}"))?
            .flatten()
        {
            let Some(name) = e.file_name().to_str().map(str::to_owned) else {
                continue;
            };
            let Ok(kind) = e.file_type() else { continue };
            if kind.is_symlink() {
                if let Some(to) = std::fs::read_link(e.path())
                    .ok()
                    .and_then(|t| t.to_str().map(str::to_owned))
                {
                    host_root.push(RootEntry::Symlink(name, to));
                }
            } else if kind.is_dir() {
                host_root.push(RootEntry::Dir(name));
            }
        }
        host_root.sort_by(|a, b| a.name().cmp(b.name()));
        Ok(Self {
            modules,
            checkout: abs(root)?,
            target: abs(target)?,
            cargo_home,
            xtask: abs(xtask)?,
            viewer: abs(viewer)?,
            usbip: abs(&usbip)?,
            host_root,
        })
    }

    /// The folders the guest must see as the host does: the checkout, the target folder,
    /// `CARGO_HOME` and the binaries' folders.
    fn kept(&self) -> Vec<&Path> {
        let mut kept = vec![self.checkout.as_path(), self.target.as_path()];
        kept.extend(self.cargo_home.as_deref());
        for bin in [&self.xtask, &self.viewer, &self.usbip] {
            kept.extend(bin.parent());
        }
        kept
    }
}

/// `s` as one word of a POSIX shell command: single-quoted, each `'` closed, escaped and
/// reopened.
fn sh_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// A path as one shell word, or an error naming it (the script is text).
fn sh_path(p: &Path) -> Result<String, String> {
    p.to_str()
        .map(sh_quote)
        .ok_or_else(|| format!("hid: {} is not UTF-8", p.display()))
}

/// The guest's `/init`: mounts, modules, the host's file system and the chroot the check runs
/// in ([`GUEST_ROOT`]), a check that the chroot has each binary, then the check, its lines on
/// the console, and power off.
pub(super) fn init_script(init: &GuestInit) -> Result<String, String> {
    let r = GUEST_ROOT;
    let mut chroot = String::new();
    chroot.push_str(&format!("mkdir -p {r}\nmount -t tmpfs guest-root {r}\n"));
    for (name, mode) in GUEST_SCRATCH {
        chroot.push_str(&format!("mkdir -m {mode} {r}/{name}\n"));
    }
    for name in GUEST_KERNEL_FS {
        chroot.push_str(&format!(
            "mkdir {r}/{name}\nmount --bind /{name} {r}/{name}\n"
        ));
    }
    let mut bound: Vec<&str> = Vec::new();
    for entry in &init.host_root {
        match entry {
            RootEntry::Dir(name)
                if GUEST_SCRATCH.iter().any(|(n, _)| n == name)
                    || GUEST_KERNEL_FS.contains(&name.as_str()) => {}
            RootEntry::Dir(name) => {
                let (host, guest) = (
                    sh_quote(&format!("/host/{name}")),
                    sh_quote(&format!("{r}/{name}")),
                );
                chroot.push_str(&format!("mkdir {guest}\nmount --bind {host} {guest}\n"));
                bound.push(name);
            }
            RootEntry::Symlink(name, to) => {
                chroot.push_str(&format!(
                    "ln -s {} {}\n",
                    sh_quote(to),
                    sh_quote(&format!("{r}/{name}"))
                ));
            }
        }
    }
    // A kept folder under one of the guest's own (a checkout under /tmp or /run) is bound
    // at its own path, outermost first, after the folders that would hide it.
    let mut explicit: Vec<&Path> = Vec::new();
    let mut kept = init.kept();
    kept.sort_by_key(|p| p.components().count());
    for p in kept {
        if !p.is_absolute() {
            return Err(format!("hid: {} is not an absolute path", p.display()));
        }
        let top = p
            .components()
            .nth(1)
            .and_then(|c| c.as_os_str().to_str())
            .unwrap_or("");
        if bound.contains(&top) || explicit.iter().any(|e| p.starts_with(e)) {
            continue;
        }
        let host = sh_path(&Path::new("/host").join(p.strip_prefix("/").unwrap_or(p)))?;
        let guest = sh_path(&Path::new(r).join(p.strip_prefix("/").unwrap_or(p)))?;
        chroot.push_str(&format!("mkdir -p {guest}\nmount --bind {host} {guest}\n"));
        explicit.push(p);
    }
    let xtask = sh_path(&init.xtask)?;
    let viewer = sh_path(&init.viewer)?;
    let usbip = sh_path(&init.usbip)?;
    let checkout = sh_path(&init.checkout)?;
    Ok(format!(
        r#"#!/bin/sh
export PATH=/bin
echo
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
echo "hid: guest booted, init at $(cut -d' ' -f1 /proc/uptime) s of guest uptime"
for m in {modules}; do insmod /lib/modules/$m.ko || echo "hid-guest: insmod $m failed"; done
echo "hid-guest: modules loaded"
ip link set lo up
mkdir -p /host
echo "hid-guest: mounting the host over 9p"
if ! mount -t 9p -o trans=virtio,version=9p2000.L,ro host /host; then
  echo "hid: FAILED: cannot mount the host's file system over 9p"; poweroff -f
fi
# The chroot: the host's folders bound at their names in a tmpfs of the guest's own, its own
# /tmp and /run (nothing mounted over the host's: a checkout under /tmp stays visible).
{chroot}missing=0
for f in {xtask} {viewer} {usbip}; do
  if [ ! -x "{r}$f" ]; then
    echo "hid: FAILED: the guest does not see $f (no executable {r}$f in its chroot)"; missing=1
  fi
done
if [ ! -d "{r}"{checkout} ]; then
  echo "hid: FAILED: the guest does not see the checkout "{checkout}; missing=1
fi
if [ $missing = 1 ]; then poweroff -f; fi
# Loopback acks at once: usbip-device's socket leaves Nagle's algorithm on, so a small
# report written while the previous one is unacknowledged waits for the kernel's delayed
# ack (40 ms) whenever the host's output reports interleave with the input reports.
for dst in 127.0.0.0/8 127.0.0.1; do
  chroot {r} /usr/sbin/ip route replace local $dst dev lo table local proto kernel scope host src 127.0.0.1 quickack 1 || echo "hid: loopback route $dst without quickack"
done
echo "hid-guest: starting the device"
cd /
chroot {r} {xtask} hid-guest-device > /dev/ttyS0 2>&1 &
attached=0
for i in 1 2 3 4 5 6 7 8 9 10; do
  sleep 1
  chroot {r} {usbip} attach -r 127.0.0.1 -b 1-1 2>&1 | sed 's/^/hid-guest: usbip: /'
  sleep 1
  if ls /sys/class/hidraw 2>/dev/null | grep -q hidraw; then attached=1; break; fi
done
echo "hid: attached after $i attempt(s) at $(cut -d' ' -f1 /proc/uptime) s of guest uptime"
dmesg | grep -E "usb 1-1|hid-generic|clocksource" | sed 's/^/hid: kernel: /'
bytes=$(timeout 5 cat /dev/hidraw0 | wc -c)
echo "hid: a plain reader (cat /dev/hidraw0, nothing written): $((bytes / 64 / 5)) reports a second over 5 s"
chroot {r} {viewer} device list 2>&1 | sed 's/^/hid: viewer device list: /'
chroot {r} {xtask} hid-guest-session {checkout} 2>&1
echo "hid: guest done at $(cut -d' ' -f1 /proc/uptime) s of guest uptime"
poweroff -f
"#,
        modules = init.modules.join(" "),
    ))
}

/// Writes the guest's initramfs: an uncompressed cpio archive ("newc") of busybox with its
/// applets, the modules and `/init`.
pub(super) fn write_initramfs(path: &Path, unpacked: &Path, init: &str) -> Result<(), String> {
    let busybox = std::fs::read(unpacked.join("bin").join("busybox"))
        .map_err(|e| format!("hid: busybox-static's bin/busybox: {e}"))?;
    let mut cpio = Cpio::default();
    for d in ["bin", "dev", "proc", "sys", "tmp", "lib", "lib/modules"] {
        cpio.dir(d);
    }
    cpio.file("bin/busybox", 0o755, &busybox);
    for applet in [
        "sh", "mount", "insmod", "ls", "cat", "cut", "sleep", "ip", "poweroff", "echo", "mkdir",
        "chroot", "grep", "sed", "dmesg", "timeout", "wc", "ln", "test", "[",
    ] {
        cpio.symlink(&format!("bin/{applet}"), "busybox");
    }
    for (name, bytes) in modules_in_order(unpacked)? {
        cpio.file(&format!("lib/modules/{name}.ko"), 0o644, &bytes);
    }
    cpio.file("init", 0o755, init.as_bytes());
    std::fs::write(path, cpio.finish()).map_err(|e| format!("hid: {}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use std::process::Command;

    use super::*;

    /// A Debian host's `/` (merged /usr: `bin`, `lib`, `lib64` and `sbin` are links).
    fn debian_root() -> Vec<RootEntry> {
        let mut root: Vec<RootEntry> = [
            "boot", "dev", "etc", "home", "media", "mnt", "opt", "proc", "root", "run", "srv",
            "sys", "tmp", "usr", "var", "work",
        ]
        .iter()
        .map(|d| RootEntry::Dir(d.to_string()))
        .collect();
        for (name, to) in [
            ("bin", "usr/bin"),
            ("lib", "usr/lib"),
            ("lib64", "usr/lib64"),
            ("sbin", "usr/sbin"),
        ] {
            root.push(RootEntry::Symlink(name.into(), to.into()));
        }
        root
    }

    /// The guest's init for a checkout, target folder and `CARGO_HOME`, the binaries where
    /// `cargo xtask hid` has them.
    fn guest_init(checkout: &str, target: &str, cargo_home: &str) -> GuestInit {
        let target = PathBuf::from(target);
        GuestInit {
            modules: vec!["usbip_core".into(), "vhci_hcd".into(), "9p".into()],
            checkout: checkout.into(),
            xtask: target.join("debug/xtask"),
            viewer: target.join("debug/viewer"),
            usbip: target.join("hid-guest/root/usr/sbin/usbip"),
            target,
            cargo_home: Some(cargo_home.into()),
            host_root: debian_root(),
        }
    }

    /// Runs `script` in the machine's `sh` with its commands replaced by shell functions that
    /// record their arguments as the shell split them (`poweroff` ends the run); returns the
    /// calls and what the script printed.
    fn dry_run(script: &str) -> (Vec<Vec<String>>, String) {
        const STUBS: &str = r#"
record() { printf '%s\037' "$@" >&2; printf '\036' >&2; }
mount() { record mount "$@"; }
mkdir() { record mkdir "$@"; }
ln() { record ln "$@"; }
chroot() { record chroot "$@"; }
poweroff() { record poweroff "$@"; exit 0; }
insmod() { :; }
ip() { :; }
cut() { echo 0; }
sleep() { :; }
ls() { echo hidraw0; }
grep() { return 0; }
dmesg() { :; }
sed() { :; }
timeout() { :; }
cat() { :; }
wc() { echo 0; }
"#;
        let script = script.replacen("export PATH=/bin\n", STUBS, 1);
        let out = Command::new("sh")
            .arg("-c")
            .arg(&script)
            .output()
            .expect("sh runs");
        assert!(
            out.status.success(),
            "sh failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        let calls = String::from_utf8_lossy(&out.stderr)
            .split('\x1e')
            .filter(|c| !c.is_empty())
            .map(|c| {
                c.split('\x1f')
                    .filter(|w| !w.is_empty())
                    .map(str::to_owned)
                    .collect()
            })
            .collect();
        (calls, String::from_utf8_lossy(&out.stdout).into_owned())
    }

    /// Checks the mounts `script` makes, as the shell ran them: nothing is mounted over the
    /// host's file system (`/host`), and inside the chroot every mount over (or at) a kept
    /// path of `init` binds the host's folder of the same path, and one does.
    fn check_mounts(init: &GuestInit, script: &str) -> Result<(), String> {
        let (calls, _) = dry_run(script);
        let mounts: Vec<(bool, &str, &str)> = calls
            .iter()
            .filter(|c| c[0] == "mount")
            .map(|c| {
                let n = c.len();
                (
                    c.contains(&"--bind".to_string()),
                    c[n - 2].as_str(),
                    c[n - 1].as_str(),
                )
            })
            .collect();
        for (_, source, target) in &mounts {
            let t = Path::new(target);
            if t.starts_with("/host") && t != Path::new("/host") {
                return Err(format!("{source} mounted over the host's {target}"));
            }
        }
        let r = Path::new(GUEST_ROOT);
        let first = mounts
            .iter()
            .position(|(_, _, t)| Path::new(t).starts_with(r))
            .ok_or("no chroot")?;
        if mounts[first] != (false, "guest-root", GUEST_ROOT) {
            return Err(format!("the chroot begins with {:?}", mounts[first]));
        }
        let named = [
            ("the checkout", Some(&init.checkout)),
            ("the target folder", Some(&init.target)),
            ("CARGO_HOME", init.cargo_home.as_ref()),
            ("xtask", Some(&init.xtask)),
            ("the viewer", Some(&init.viewer)),
            ("usbip", Some(&init.usbip)),
        ];
        for (what, path) in named {
            let Some(path) = path else { continue };
            // The mounts over (or at) the path, in order: the host's folder of the same path
            // each, but for the guest's own /dev (/proc, /sys), under which a kept path (a
            // checkout in /dev/shm) must then be bound again.
            let over: Vec<&(bool, &str, &str)> = mounts[first + 1..]
                .iter()
                .filter(|(_, _, target)| {
                    Path::new(target)
                        .strip_prefix(r)
                        .is_ok_and(|inside| path.starts_with(Path::new("/").join(inside)))
                })
                .collect();
            let covered = over.last().is_some_and(|(bind, source, target)| {
                *bind
                    && Path::new(source)
                        == Path::new("/host")
                            .join(Path::new(target).strip_prefix(r).unwrap_or(Path::new("")))
            });
            for (bind, source, target) in &over {
                let inside = Path::new(target).strip_prefix(r).unwrap_or(Path::new(""));
                let identity = *bind && Path::new(source) == Path::new("/host").join(inside);
                let kernel_fs = *bind
                    && GUEST_KERNEL_FS
                        .iter()
                        .any(|k| Path::new(source) == Path::new("/").join(k));
                if !(identity || kernel_fs && covered) {
                    return Err(format!(
                        "{what} {} is under {target}, mounted from {source}",
                        path.display()
                    ));
                }
            }
            if !covered {
                return Err(format!(
                    "{what} {} is in the guest's own tmpfs, not the host's",
                    path.display()
                ));
            }
        }
        if let Some(c) = calls
            .iter()
            .find(|c| c[0] == "chroot" && c.get(1).map(String::as_str) != Some(GUEST_ROOT))
        {
            return Err(format!("a chroot elsewhere: {c:?}"));
        }
        Ok(())
    }

    /// The checkouts of issue 35 (under /tmp, as `mktemp -d` makes them; /run; /var/run, a
    /// folder where it is not a link to /run, which `from_host`'s canonical paths have
    /// resolved otherwise; a space), with the target folder and `CARGO_HOME` inside, beside
    /// or elsewhere; a quote and a `$` in a name; a checkout in /dev/shm.
    const LAYOUTS: &[(&str, &str, &str)] = &[
        (
            "/tmp/tmp.Xq3vRk9/repo",
            "/tmp/tmp.Xq3vRk9/repo/target",
            "/root/.cargo",
        ),
        ("/tmp/repo", "/work/target", "/tmp/cargo"),
        (
            "/run/user/1000/repo",
            "/run/user/1000/repo/target",
            "/run/user/1000/cargo",
        ),
        ("/var/run/repo", "/var/run/repo/target", "/var/run/cargo"),
        ("/tmp/x y/repo", "/tmp/x y/target", "/tmp/x y/cargo home"),
        ("/home/u/it's $HOME/repo", "/tmp/t", "/home/u/.cargo"),
        ("/dev/shm/repo", "/dev/shm/repo/target", "/dev/shm/cargo"),
    ];

    /// The guest's init never mounts over a folder that holds the checkout, the target folder
    /// or `CARGO_HOME`: each is the host's own in the chroot, wherever it is (issue 35: a
    /// tmpfs on /host/tmp hid a checkout under /tmp).
    #[test]
    fn the_guest_sees_the_checkout_wherever_it_is() {
        for &(checkout, target, cargo_home) in LAYOUTS {
            let init = guest_init(checkout, target, cargo_home);
            let script = init_script(&init).expect("the script of a UTF-8 layout");
            if let Err(e) = check_mounts(&init, &script) {
                panic!(
                    "checkout {checkout}, target {target}, CARGO_HOME {cargo_home}: {e}\n{script}"
                );
            }
        }
    }

    /// The check itself catches the shadowing of issue 35, and a scratch tmpfs mounted in
    /// the chroot over a kept path.
    #[test]
    fn the_mount_check_catches_a_hidden_checkout() {
        let init = guest_init("/tmp/x y/repo", "/tmp/x y/target", "/root/.cargo");
        let script = init_script(&init).expect("the script of a UTF-8 layout");
        let marker = "missing=0\n";
        for extra in [
            "mount -t tmpfs tmp /host/tmp\n",
            "mount -t tmpfs tmp /guest-root/tmp\n",
            "mount -t tmpfs tmp '/guest-root/tmp/x y'\n",
        ] {
            let bad = script.replacen(marker, &format!("{extra}{marker}"), 1);
            assert!(check_mounts(&init, &bad).is_err(), "{extra} not caught");
        }
        let unbound = script.replace("mount --bind '/host/tmp/x y/repo'", ": ");
        assert!(check_mounts(&init, &unbound).is_err());
    }

    /// Before it starts anything the guest checks that it sees each binary and the checkout,
    /// and says which it does not (none exists under /guest-root on the machine the tests
    /// run on).
    #[test]
    fn the_guest_names_a_binary_it_does_not_see() {
        let init = guest_init("/tmp/x y/repo", "/tmp/x y/target", "/root/.cargo");
        let (calls, out) = dry_run(&init_script(&init).expect("the script of a UTF-8 layout"));
        for missing in [
            "/tmp/x y/target/debug/xtask",
            "/tmp/x y/target/debug/viewer",
            "/tmp/x y/target/hid-guest/root/usr/sbin/usbip",
        ] {
            assert!(
                out.contains(&format!(
                    "hid: FAILED: the guest does not see {missing} (no executable /guest-root{missing} in its chroot)"
                )),
                "{out}"
            );
        }
        assert!(out.contains("hid: FAILED: the guest does not see the checkout /tmp/x y/repo"));
        assert_eq!(
            calls.last().map(Vec::as_slice),
            Some(&["poweroff".to_string(), "-f".to_string()][..])
        );
        assert!(!calls.iter().any(|c| c[0] == "chroot"), "{calls:?}");
    }

    /// A quoted word is the string itself to the shell, whatever it holds.
    #[test]
    fn shell_quoting_keeps_every_character() {
        for s in ["/tmp/x y/repo", "it's", "$HOME `id` \"q\" \\ *", "a\tb", ""] {
            let out = Command::new("sh")
                .arg("-c")
                .arg(format!("printf '%s' {}", sh_quote(s)))
                .output()
                .expect("sh runs");
            assert_eq!(String::from_utf8_lossy(&out.stdout), s);
        }
    }
}
