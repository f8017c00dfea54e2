//! Why does a plane label win over the non-planar label on a non-planar pixel? Splits the
//! data costs of both on a `planemap synth` workspace's ground-truth non-planar pixels where
//! the label's sweep depth is right (within 1 %) and confident — the pixels the label should
//! take.
//!
//! Per view: how many such pixels there are, and the mean over them of the non-planar
//! label's classifier and photo costs against the cheapest plane label's planar data cost
//! (visibility + photo), its classifier cost and its fit-gap cost. Classifier overconfidence,
//! a photo term on a different scale, or a plane that matches the images as well: the split
//! says which.

use std::path::PathBuf;

use super::{DiagResult, Workspace};
use crate::nonplanar::NonplanarView;
use crate::pipeline::{self, Config};

/// Options of `planemap diag nonplanar`.
#[derive(Debug, Clone, clap::Args)]
pub struct NonplanarArgs {
    /// A `planemap synth` workspace (sparse/, images/, gt/).
    pub workspace: PathBuf,
    /// Views to audit (indices in image-id order; default: all).
    pub views: Vec<usize>,
    /// Override a planemap config value (repeatable); `nonplanar.enabled=true` is implied.
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub overrides: Vec<String>,
}

/// Runs the audit.
pub fn run(args: &NonplanarArgs) -> DiagResult {
    let mut overrides = vec!["nonplanar.enabled=true".to_string()];
    overrides.extend(args.overrides.iter().cloned());
    let cfg = crate::config::with_overrides(&Config::default(), &overrides)?;
    let ws = Workspace::open(&args.workspace)?;
    let scene = &ws.scene;
    let views = ws.views(&args.views)?;
    let prepared = pipeline::prepare(scene, &cfg)?;
    let images = prepared.images.as_ref().ok_or("no images")?;
    let model = prepared.classifier.as_ref().ok_or("no classifier")?;
    let np = &cfg.nonplanar;
    for &v in &views {
        let view = &scene.views[v];
        let gt = ws.gt_pfm("depth", v)?;
        let ids = ws.gt_plane_ids(v)?;
        let energy = pipeline::view_energy(scene, &prepared, v, &images[v], &cfg)?;
        let ev = NonplanarView::compute(
            scene,
            images,
            v,
            &prepared.axes.directions,
            &energy.planes,
            model,
            np,
        )?;
        let costs = ev
            .planarity
            .unary_costs(np.beta as f32, np.epsilon as f32)?;
        let w = cfg.planemap.photo_weight as f32;
        let labels = energy.num_labels();
        let (mut count, mut np_cls, mut np_photo, mut pl_data, mut pl_cls, mut pl_gap) =
            (0usize, 0f64, 0f64, 0f64, 0f64, 0f64);
        let mut np_cheaper = 0usize;
        for (p, (&g, &id)) in gt.data.iter().zip(&ids).enumerate() {
            let z = ev.depth[p];
            if g <= 0.0 || id != 0 || z <= 0.0 || (z - g).abs() > 0.01 * g {
                continue;
            }
            count += 1;
            let best = (0..labels as u32)
                .map(|a| energy.unary(p, a))
                .fold(f32::INFINITY, f32::min);
            let (c_np, c_photo) = (costs.nonplanar[p], w * ev.cost[p]);
            let (c_pl, c_gap) = (costs.planar[p], ev.fit_gap_cost(p, np));
            np_cls += c_np as f64;
            np_photo += c_photo as f64;
            pl_data += best as f64;
            pl_cls += c_pl as f64;
            pl_gap += c_gap as f64;
            np_cheaper += usize::from(c_np + c_photo < best + c_pl + c_gap);
        }
        let m = |x: f64| x / count.max(1) as f64;
        println!(
            "{}: {count} non-planar pixels with a right, confident sweep depth; the label's data cost is lower on {np_cheaper}. Means — label: classifier {:.3} + photo {:.3}; cheapest plane: data {:.3} + classifier {:.3} + fit gap {:.3}",
            view.name,
            m(np_cls),
            m(np_photo),
            m(pl_data),
            m(pl_cls),
            m(pl_gap)
        );
    }
    Ok(())
}
