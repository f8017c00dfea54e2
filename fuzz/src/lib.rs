//! Fuzz targets for planemap's readers; see `README.md`.
pub mod readers;
