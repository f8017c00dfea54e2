//! Tests of the generator: determinism, the TOML round trip, and that every kind draws what
//! it says at a tiny size.

use super::*;
use crate::synth::{render, RenderOptions};

fn quiet(_: usize, _: usize) {}

const TINY: GenerateOptions = GenerateOptions {
    width: 96,
    height: 72,
};

#[test]
fn kind_names_round_trip() {
    for k in Kind::ALL {
        assert_eq!(Kind::from_name(k.name()), Some(k));
        assert_eq!(k.to_string(), k.name());
    }
    assert_eq!(Kind::from_name(" street "), Some(Kind::Street));
    assert_eq!(Kind::from_name("castle"), None);
}

#[test]
fn seeds_split_into_development_and_test() {
    assert_eq!(split(0), "development");
    assert_eq!(split(999), "development");
    assert_eq!(split(1000), "test");
    assert_eq!(split(1999), "test");
    assert_eq!(split(2000), "reserved");
}

#[test]
fn same_kind_and_seed_give_the_same_scene_and_others_differ() {
    for k in Kind::ALL {
        let a = generate(k, 7, &TINY).unwrap();
        let b = generate(k, 7, &TINY).unwrap();
        assert_eq!(a.toml, b.toml, "{k}");
        let c = generate(k, 8, &TINY).unwrap();
        assert_ne!(
            a.spec.objects, c.spec.objects,
            "{k}: seeds 7 and 8 draw the same objects"
        );
        assert_eq!(a.spec.name, format!("{k}-0007"));
        assert_eq!(a.spec.category, k.category());
        assert!(a
            .toml
            .starts_with(&format!("# {k}-0007: a generated {k} scene")));
    }
    // The kind keys the stream: two kinds with one seed are not one draw in two shapes.
    let a = generate(Kind::Street, 3, &TINY).unwrap();
    let b = generate(Kind::Plaza, 3, &TINY).unwrap();
    assert_ne!(a.spec.seed, b.spec.seed);
}

#[test]
fn the_toml_parses_back_to_the_scene() {
    for k in Kind::ALL {
        let g = generate(k, 11, &GenerateOptions::default()).unwrap();
        let parsed = SceneSpec::from_toml_str(&g.toml, "scene.toml").unwrap();
        assert_eq!(parsed, g.spec, "{k}");
        assert_eq!((g.spec.camera.width, g.spec.camera.height), (320, 240));
        // Re-serialising the parsed scene writes the same body (gt/scene.toml of both
        // renders is then the same file).
        let body = toml::to_string_pretty(&parsed).unwrap();
        assert!(g.toml.ends_with(&body), "{k}");
    }
}

#[test]
fn zero_or_huge_sizes_are_errors_naming_the_scene() {
    let err = generate(
        Kind::Hall,
        0,
        &GenerateOptions {
            width: 0,
            height: 10,
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("0x10"), "{err}");
    // A size over the renderer's limits is refused naming the generated scene.
    let huge = GenerateOptions {
        width: 100_000,
        height: 240,
    };
    let err = generate(Kind::Hall, 2, &huge).unwrap_err().to_string();
    assert!(
        err.contains("hall-0002 (generated)") && err.contains("camera.width 100000"),
        "{err}"
    );
}

/// Every kind, two seeds, rendered at 96×72: the planar and non-planar shares in the kind's
/// ranges, no view mostly sky, a real view count, sparse points, and the material mix.
#[test]
fn every_kind_renders_what_it_promises() {
    for k in Kind::ALL {
        for seed in [0, 1] {
            let g = generate(k, seed, &TINY).unwrap();
            let s = render(&g.spec, &RenderOptions::default(), &quiet).unwrap();
            let st = scene_stats(&s);
            eprintln!("{k}-{seed}: {st:?}\n  {}", g.spec.description);
            assert!(
                (8..=24).contains(&st.views),
                "{k}-{seed}: {} views",
                st.views
            );
            assert!(
                k.planar_range().contains(&st.planar),
                "{k}-{seed}: planar share {:.3} not in {:?}",
                st.planar,
                k.planar_range()
            );
            assert!(
                k.nonplanar_range().contains(&st.nonplanar),
                "{k}-{seed}: non-planar share {:.3} not in {:?}",
                st.nonplanar,
                k.nonplanar_range()
            );
            assert!(
                st.min_view_surface >= 0.5,
                "{k}-{seed}: a view is {:.0} % sky",
                100.0 * (1.0 - st.min_view_surface)
            );
            assert!(st.points >= 50, "{k}-{seed}: {} sparse points", st.points);
            // Plain paint (or render) on 30–70 % of the wall or facade area, as drawn.
            let d = &g.spec.description;
            let from = d
                .find("plain ")
                .expect("the description gives the plain share");
            let at = from + d[from..].find(" on ").unwrap() + 4;
            let painted: f64 = d[at..].split(' ').next().unwrap().parse().unwrap();
            assert!((30.0..=70.0).contains(&painted), "{k}-{seed}: {d}");
            assert!(
                st.plain > 0.1 && st.plain < 0.9,
                "{k}-{seed}: plain share {:.3}",
                st.plain
            );
        }
    }
}

/// Plazas reach their non-planar band on every seed, not only on the two rendered above:
/// generator v1 stopped at 5 % of the probe rays on plaza-1000, the test split's first plaza,
/// when no spot for another object was left on the views' lines of sight.
#[test]
fn plazas_reach_their_non_planar_band() {
    for seed in (0..8).chain(996..1004) {
        let g = generate(Kind::Plaza, seed, &TINY).unwrap();
        let d = &g.spec.description;
        let at = d
            .find("probe rays ")
            .expect("the description gives the share")
            + 11;
        let share: f64 = d[at..].split(' ').next().unwrap().parse().unwrap();
        assert!((12.0..=32.0).contains(&share), "plaza-{seed}: {d}");
    }
    let g = generate(Kind::Plaza, 1000, &TINY).unwrap();
    let s = render(&g.spec, &RenderOptions::default(), &quiet).unwrap();
    let st = scene_stats(&s);
    assert!(
        Kind::Plaza.nonplanar_range().contains(&st.nonplanar),
        "plaza-1000: rendered non-planar share {:.3}",
        st.nonplanar
    );
}
