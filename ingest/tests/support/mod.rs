//! Helpers shared by the test modules: mutations of layer files for the fuzzer (`mutate`) and zip
//! checksum repair for mutated packages (`zip`).

pub mod mutate;
pub mod zip;
