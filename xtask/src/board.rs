//! The board binary's check in `cargo xtask ci`: a release build of `firmware`'s `board`
//! binary (STM32F411CE) and its budget, flash ≤ 128 KiB and RAM ≤ 32 KiB with the stack.
//!
//! Static RAM is `data + bss` of the ELF (RTIC's task resources are in `.uninit`, counted with
//! `bss`); the stack is not in the ELF, so a reserve for it is added: [`STACK_RESERVE`], the
//! worst case of the firmware's call graph with every priority nested (see the firmware
//! README, "Budget").

use std::path::Path;

use crate::EMBEDDED_TARGET;
use crate::qemu::{elf_sizes, firmware_target_dir, workspace_root};

/// Flash budget of the board build (bytes).
pub const FLASH_BUDGET: u64 = 128 * 1024;
/// RAM budget of the board build, stack included (bytes).
pub const RAM_BUDGET: u64 = 32 * 1024;
/// Stack reserved on top of the statics (bytes): the deepest nesting of the firmware's call
/// graph (read off the release build's disassembly: frame sizes along the deepest calls,
/// every priority preempting the one below; about 11.8 KB since no chain is built on a
/// stack, 14.5 KB before; see the firmware README), with room for the USB class's indirect
/// calls, which are not followed. Not measured on hardware.
pub const STACK_RESERVE: u64 = 15 * 1024;

/// Builds the board binary (release) and checks its sizes.
pub fn check_board(cargo: &str) -> Result<(), String> {
    let root = workspace_root()?;
    let target_dir = firmware_target_dir(&root);
    let target = target_dir.to_string_lossy().into_owned();
    crate::run_in(
        &root.join("firmware"),
        cargo,
        &["build", "--release", "--bin", "board"],
        &[("CARGO_TARGET_DIR", target.as_str())],
    )?;
    let elf = target_dir
        .join(EMBEDDED_TARGET)
        .join("release")
        .join("board");
    check_sizes(&elf)
}

fn check_sizes(elf: &Path) -> Result<(), String> {
    let s = elf_sizes(elf)?;
    let flash = s.text + s.data;
    let ram = s.data + s.bss + STACK_RESERVE;
    println!(
        "size elf=board text={} data={} bss={} flash={flash} ram_static={} stack_reserve={} \
         ram={ram}",
        s.text,
        s.data,
        s.bss,
        s.data + s.bss,
        STACK_RESERVE
    );
    within_budget(flash, ram)
}

/// `Ok` when both are within the budget, else what is over and by how much.
fn within_budget(flash: u64, ram: u64) -> Result<(), String> {
    let mut over = Vec::new();
    if flash > FLASH_BUDGET {
        over.push(format!(
            "flash {flash} bytes > {FLASH_BUDGET} (by {})",
            flash - FLASH_BUDGET
        ));
    }
    if ram > RAM_BUDGET {
        over.push(format!(
            "RAM {ram} bytes (statics + {STACK_RESERVE} of stack) > {RAM_BUDGET} (by {})",
            ram - RAM_BUDGET
        ));
    }
    if over.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "the board build is over budget: {}",
            over.join("; ")
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_budget_takes_its_edges_and_refuses_one_byte_more() {
        assert!(within_budget(FLASH_BUDGET, RAM_BUDGET).is_ok());
        let flash = within_budget(FLASH_BUDGET + 1, RAM_BUDGET).expect_err("one byte over");
        assert!(flash.contains("flash") && !flash.contains("RAM"), "{flash}");
        let ram = within_budget(0, RAM_BUDGET + 1).expect_err("one byte over");
        assert!(ram.contains("RAM") && ram.contains("by 1"), "{ram}");
    }
}
