//! Reads every file of a directory (e.g. a fuzz corpus) and prints how many are valid and how many
//! fail each rule, as raw bytes and after `repair_checksums`:
//! `cargo run -p spherebake-format --example rule_histogram -- fuzz/corpus/load`.

use std::collections::BTreeMap;

fn main() -> std::io::Result<()> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| ".".into());
    let mut raw: BTreeMap<u16, usize> = BTreeMap::new();
    let mut repaired: BTreeMap<u16, usize> = BTreeMap::new();
    let mut entries: Vec<_> = std::fs::read_dir(&dir)?.collect::<Result<_, _>>()?;
    entries.sort_by_key(|e| e.path());
    for entry in entries {
        let mut bytes = std::fs::read(entry.path())?;
        let id = |b: &[u8]| spherebake_format::read(b).err().map_or(0, |e| e.rule.id());
        *raw.entry(id(&bytes)).or_default() += 1;
        spherebake_format::repair_checksums(&mut bytes);
        *repaired.entry(id(&bytes)).or_default() += 1;
    }
    println!("rule (0 = valid): files as given / after repair_checksums");
    let keys: std::collections::BTreeSet<u16> = raw.keys().chain(repaired.keys()).copied().collect();
    for k in keys {
        println!("{k:>5}: {:>5} / {:>5}", raw.get(&k).copied().unwrap_or(0), repaired.get(&k).copied().unwrap_or(0));
    }
    Ok(())
}
