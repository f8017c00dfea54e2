//! Exchange format: one labelling problem as a directory of `.npy` files mirroring GCO's
//! general-graph inputs (`gco-wrapper`'s `cut_general_graph`), so peer solvers solve the very
//! same instance.
//!
//! | file               | shape   | meaning                                              |
//! |--------------------|---------|------------------------------------------------------|
//! | `unary.npy`        | `N × L` | data cost `D(p, l)`                                  |
//! | `edges.npy`        | `E × 2` | undirected edges `(p, q)`, integer site indices      |
//! | `edge_weights.npy` | `E`     | `w_pq` (optional, default 1)                         |
//! | `pairwise.npy`     | `L × L` | `V(a, b)`; the pair cost is `w_pq · V(a, b)`          |
//! | `init_labels.npy`  | `N`     | initial labelling (optional)                         |
//!
//! Values may be any float or integer dtype. Integer-valued instances are solved exactly
//! with integer capacities by `gcsolve`.
use std::path::{Path, PathBuf};

use crate::npy::{read_npy_path, write_npy_path, NpyError};

/// Errors reading or writing an exchange directory.
#[derive(Debug, thiserror::Error)]
pub enum ExchangeError {
    /// A `.npy` file could not be read or written.
    #[error(transparent)]
    Npy(#[from] NpyError),
    /// An array has the wrong shape.
    #[error("{path}: shape {got:?}, expected {expected}")]
    Shape {
        /// The file.
        path: PathBuf,
        /// Its shape.
        got: Vec<usize>,
        /// What was expected.
        expected: String,
    },
    /// The directory could not be created.
    #[error("{path}: {source}")]
    Io {
        /// The directory.
        path: PathBuf,
        /// The failure.
        source: std::io::Error,
    },
}

/// One labelling problem in exchange form (values as `f64`).
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Number of sites `N`.
    pub num_sites: usize,
    /// Number of labels `L`.
    pub num_labels: usize,
    /// `N × L` data costs, site-major.
    pub unary: Vec<f64>,
    /// Undirected edges.
    pub edges: Vec<[u32; 2]>,
    /// One weight per edge.
    pub edge_weights: Vec<f64>,
    /// `L × L` label-pair costs.
    pub pairwise: Vec<f64>,
    /// Optional initial labelling.
    pub initial: Option<Vec<u32>>,
}

fn shape_err(path: PathBuf, got: &[usize], expected: String) -> ExchangeError {
    ExchangeError::Shape {
        path,
        got: got.to_vec(),
        expected,
    }
}

impl Instance {
    /// Whether every cost is an integer of magnitude below `limit` (then integer capacities
    /// solve it exactly).
    pub fn is_integral(&self, limit: f64) -> bool {
        let ok = |v: &f64| v.fract() == 0.0 && v.abs() < limit;
        self.unary.iter().all(ok)
            && self.edge_weights.iter().all(ok)
            && self.pairwise.iter().all(ok)
    }

    /// If the edges are exactly the 4-connected `W × H` grid over the sites (each horizontal
    /// and vertical neighbour pair once, any order), returns `W`, `H` and, per edge, its
    /// grid edge slot (`p * 2` for `p → p+1`, `p * 2 + 1` for `p → p+W`).
    pub fn detect_grid4(&self) -> Option<(usize, usize, Vec<usize>)> {
        let n = self.num_sites;
        let w = self
            .edges
            .iter()
            .map(|&[p, q]| p.abs_diff(q) as usize)
            .max()?;
        let w = if w == 1 { n } else { w };
        if w == 0 || n % w != 0 {
            return None;
        }
        let h = n / w;
        if self.edges.len() != (w - 1) * h + w * (h - 1) {
            return None;
        }
        let mut seen = vec![false; 2 * n];
        let mut slots = Vec::with_capacity(self.edges.len());
        for &[p, q] in &self.edges {
            let (a, b) = (p.min(q) as usize, p.max(q) as usize);
            let slot = if b == a + 1 && a % w != w - 1 {
                2 * a
            } else if b == a + w && w > 1 {
                2 * a + 1
            } else {
                return None;
            };
            if seen[slot] {
                return None;
            }
            seen[slot] = true;
            slots.push(slot);
        }
        Some((w, h, slots))
    }
}

/// Reads an exchange directory.
pub fn read_instance(dir: &Path) -> Result<Instance, ExchangeError> {
    let path = |f: &str| dir.join(f);
    let unary = read_npy_path(&path("unary.npy"))?;
    if unary.shape.len() != 2 {
        return Err(shape_err(path("unary.npy"), &unary.shape, "N x L".into()));
    }
    let (n, l) = (unary.shape[0], unary.shape[1]);
    let edges = read_npy_path(&path("edges.npy"))?;
    if edges.shape.len() != 2 || edges.shape[1] != 2 {
        return Err(shape_err(path("edges.npy"), &edges.shape, "E x 2".into()));
    }
    let ne = edges.shape[0];
    let flat = edges.to_u32()?;
    let edge_list: Vec<[u32; 2]> = flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    let wpath = path("edge_weights.npy");
    let edge_weights = if wpath.exists() {
        let w = read_npy_path(&wpath)?;
        if w.len() != ne || w.shape.len() != 1 {
            return Err(shape_err(wpath, &w.shape, format!("({ne},)")));
        }
        w.to_f64()
    } else {
        vec![1.0; ne]
    };
    let pw = read_npy_path(&path("pairwise.npy"))?;
    if pw.shape != [l, l] {
        return Err(shape_err(
            path("pairwise.npy"),
            &pw.shape,
            format!("{l} x {l}"),
        ));
    }
    let ipath = path("init_labels.npy");
    let initial = if ipath.exists() {
        let a = read_npy_path(&ipath)?;
        if a.len() != n {
            return Err(shape_err(ipath, &a.shape, format!("({n},)")));
        }
        Some(a.to_u32()?)
    } else {
        None
    };
    Ok(Instance {
        num_sites: n,
        num_labels: l,
        unary: unary.to_f64(),
        edges: edge_list,
        edge_weights,
        pairwise: pw.to_f64(),
        initial,
    })
}

/// Writes an exchange directory (creating it; each file via a temporary name). Integer
/// valued instances are written as `int32` where they fit, like the benchmark generator.
pub fn write_instance(dir: &Path, inst: &Instance) -> Result<(), ExchangeError> {
    std::fs::create_dir_all(dir).map_err(|source| ExchangeError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let integral = inst.is_integral(2f64.powi(31));
    let put = |name: &str, shape: &[usize], v: &[f64]| -> Result<(), NpyError> {
        if integral {
            let iv: Vec<i32> = v.iter().map(|&x| x as i32).collect();
            write_npy_path(&dir.join(name), shape, &iv)
        } else {
            write_npy_path(&dir.join(name), shape, v)
        }
    };
    put("unary.npy", &[inst.num_sites, inst.num_labels], &inst.unary)?;
    let flat: Vec<i32> = inst
        .edges
        .iter()
        .flat_map(|e| [e[0] as i32, e[1] as i32])
        .collect();
    write_npy_path(&dir.join("edges.npy"), &[inst.edges.len(), 2], &flat)?;
    put("edge_weights.npy", &[inst.edges.len()], &inst.edge_weights)?;
    put(
        "pairwise.npy",
        &[inst.num_labels, inst.num_labels],
        &inst.pairwise,
    )?;
    if let Some(init) = &inst.initial {
        let iv: Vec<i32> = init.iter().map(|&x| x as i32).collect();
        write_npy_path(&dir.join("init_labels.npy"), &[init.len()], &iv)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_instance(w: usize, h: usize, shuffle: bool) -> Instance {
        let mut edges = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let p = (y * w + x) as u32;
                if x + 1 < w {
                    edges.push([p, p + 1]);
                }
                if y + 1 < h {
                    edges.push(if shuffle {
                        [p + w as u32, p]
                    } else {
                        [p, p + w as u32]
                    });
                }
            }
        }
        if shuffle {
            edges.reverse();
        }
        let n = w * h;
        Instance {
            num_sites: n,
            num_labels: 2,
            unary: (0..2 * n).map(|i| (i % 7) as f64).collect(),
            edge_weights: (0..edges.len()).map(|i| (i % 3) as f64).collect(),
            edges,
            pairwise: vec![0.0, 1.0, 1.0, 0.0],
            initial: Some((0..n as u32).map(|p| p % 2).collect()),
        }
    }

    #[test]
    fn round_trip_and_grid_detection() -> Result<(), ExchangeError> {
        let dir = tempfile::tempdir().map_err(|source| ExchangeError::Io {
            path: "tmp".into(),
            source,
        })?;
        let inst = grid_instance(5, 4, true);
        write_instance(dir.path(), &inst)?;
        let back = read_instance(dir.path())?;
        assert_eq!(back, inst);
        let (w, h, slots) = back.detect_grid4().expect("a grid");
        assert_eq!((w, h), (5, 4));
        // After reversal the first edge is the last one pushed: 18 → 19 (right).
        assert_eq!(slots[0], 2 * 18);
        assert_eq!(slots[4], 2 * 14 + 1); // after the 4 right edges of the last row: (19, 14)
        let mut bad = inst.clone();
        bad.edges[0] = [0, 6];
        assert!(bad.detect_grid4().is_none());
        assert!(grid_instance(7, 1, false).detect_grid4().is_some());
        Ok(())
    }

    #[test]
    fn shape_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let inst = grid_instance(3, 3, false);
        write_instance(dir.path(), &inst).unwrap();
        write_npy_path(&dir.path().join("pairwise.npy"), &[3], &[0i32, 1, 2]).unwrap();
        let e = read_instance(dir.path()).unwrap_err();
        assert!(e.to_string().contains("pairwise.npy"), "{e}");
    }
}
