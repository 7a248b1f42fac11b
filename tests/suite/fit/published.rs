//! The published ABC and SGD fits of the MERL materials (pipeline/fit/src/published.rs) against the
//! reference values of shared/data/published-fits/golden.json, the copies the binary carries, and the
//! refusals of bad files.

use crate::common;

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use twoscale_fit::published::PublishedFits;

/// Every material of both models, found by its name, at golden.json's 80 direction pairs: within 1e-9
/// relative. The reference has 10 significant digits, a rounding of up to 5e-10 relative (at a
/// leading 1), so the largest difference is also printed in units of the last stored digit: at most
/// 1/2 where the evaluation rounds to the stored value.
#[test]
fn published_fits_match_the_reference_values() {
    let dir = common::shared_data().join("published-fits");
    let fits = PublishedFits::read(&dir).unwrap();
    let golden: Value = serde_json::from_slice(&std::fs::read(dir.join("golden.json")).unwrap()).unwrap();
    let directions: Vec<[[f64; 3]; 2]> = serde_json::from_value(golden["directions"].clone()).unwrap();
    assert_eq!(directions.len(), 80);
    for (model, listed) in [
        ("abc", fits.abc.iter().map(|e| e.material.as_str()).collect::<BTreeSet<_>>()),
        ("sgd", fits.sgd.iter().map(|e| e.material.as_str()).collect()),
    ] {
        let values: BTreeMap<String, Vec<[f64; 3]>> = serde_json::from_value(golden[model].clone()).unwrap();
        assert!(
            values.keys().map(String::as_str).eq(listed),
            "{model}: golden.json's materials are not {model}.json's"
        );
        let (mut worst, mut digits, mut at) = (0.0f64, 0.0f64, String::new());
        for (material, values) in &values {
            let found = fits.find(material).unwrap();
            assert_eq!(found.material, material);
            assert_eq!(values.len(), directions.len(), "{model}, {material}");
            for (n, (&[wi, wo], want)) in directions.iter().zip(values).enumerate() {
                let got = if model == "abc" { found.abc.unwrap().rho(wi, wo) } else { found.sgd.unwrap().rho(wi, wo) };
                for ch in 0..3 {
                    // the floor keeps an exact 0 to an exact 0
                    let (diff, scale) = ((got[ch] - want[ch]).abs(), want[ch].abs().max(1e-300));
                    assert!(
                        diff <= 1e-9 * scale,
                        "{model}, {material}, direction pair {n}, channel {ch}: {} against {}",
                        got[ch],
                        want[ch]
                    );
                    if diff > worst * scale {
                        (worst, at) = (diff / scale, format!("{material}, pair {n}, channel {ch}"));
                    }
                    digits = digits.max(diff / 10f64.powf(scale.log10().floor() - 9.0));
                }
            }
        }
        println!(
            "{model}: {} materials x {} direction pairs, largest relative difference {worst:.2e} ({at}), \
             {digits:.4} of the last stored digit",
            values.len(),
            directions.len()
        );
    }
}

/// The copies the binary carries (pipeline/fit/data/published-fits, `PublishedFits::carried`) are the
/// shared data's files, byte for byte, and read as the same fits.
#[test]
fn the_carried_published_fits_are_the_shared_datas() {
    let shared = common::shared_data().join("published-fits");
    let carried = common::repo_root().join(twoscale_fit::published::CARRIED);
    for file in ["abc.json", "sgd.json"] {
        let (a, b) = (std::fs::read(shared.join(file)).unwrap(), std::fs::read(carried.join(file)).unwrap());
        assert!(a == b, "{file}: the carried copy is not the shared data's");
    }
    let (read, built_in) = (PublishedFits::read(&shared).unwrap(), PublishedFits::carried());
    assert_eq!((read.abc.len(), read.sgd.len()), (100, 100));
    assert_eq!((built_in.abc.len(), built_in.sgd.len()), (100, 100));
    assert!(read.abc.iter().zip(&built_in.abc).all(|(x, y)| x.material == y.material && x.fit == y.fit));
    assert!(read.sgd.iter().zip(&built_in.sgd).all(|(x, y)| x.material == y.material && x.fit == y.fit));
}

/// A missing file, a file that is not a JSON list, an entry without a key or with a value of the wrong
/// type, two entries of one name: one line naming the file and what is wrong.
#[test]
fn bad_published_fits_are_refused_with_one_line() {
    let src = common::shared_data().join("published-fits");
    let list = |file: &str| -> Vec<Value> { serde_json::from_slice(&std::fs::read(src.join(file)).unwrap()).unwrap() };
    let (abc, sgd) = (list("abc.json"), list("sgd.json"));
    let edited = |good: &[Value], edit: &dyn Fn(&mut serde_json::Map<String, Value>)| {
        let mut entries = good.to_vec();
        edit(entries[0].as_object_mut().unwrap());
        serde_json::to_vec(&entries).unwrap()
    };
    // `file` holds `bytes` (None: absent), the other file is good
    let case = |file: &str, bytes: Option<Vec<u8>>, needle: &str| {
        let work = common::tempdir();
        for (name, good) in [("abc.json", &abc), ("sgd.json", &sgd)] {
            let bytes = if name == file { bytes.clone() } else { Some(serde_json::to_vec(good).unwrap()) };
            if let Some(bytes) = bytes {
                std::fs::write(work.path().join(name), bytes).unwrap();
            }
        }
        let message = format!("{:#}", PublishedFits::read(work.path()).unwrap_err());
        let path = work.path().join(file).display().to_string();
        assert!(!message.contains('\n') && message.contains(&path) && message.contains(needle), "{message}");
    };
    case("abc.json", None, "abc.json: cannot read");
    case("abc.json", Some(br#"{"material": "alum-bronze"}"#.to_vec()), "abc.json: not a JSON list");
    case("sgd.json", Some(edited(&sgd, &|e| e.clear())), "entry 0: missing field `material`");
    case(
        "abc.json",
        Some(edited(&abc, &|e| {
            e.remove("ior");
        })),
        "entry 0 (alum-bronze): missing field `ior`",
    );
    let other = edited(&sgd, &|e| {
        e.remove("other_name");
    });
    case("sgd.json", Some(other), "entry 0 (alum-bronze): missing field `other_name`");
    let scalar = edited(&sgd, &|e| {
        e.insert("alpha".into(), 0.5.into());
    });
    case("sgd.json", Some(scalar), "entry 0 (alum-bronze): invalid type: floating point `0.5`, expected an array");
    let twice = edited(&sgd, &|e| {
        e.insert("other_name".into(), "Alumina_Oxide".into());
    });
    case("sgd.json", Some(twice), "entries 0 and 1 are both named \"alumina-oxide\"");
}
