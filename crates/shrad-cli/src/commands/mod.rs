//! One file per command. Each loads what it needs, drives the library's engine (or the
//! bench harness) and writes its outputs; a new command is a new file here and one line in
//! `Command` (main.rs).

pub mod animate;
pub mod bake;
pub mod bench;
pub mod info;
pub mod options;
pub mod render;
pub mod view;
