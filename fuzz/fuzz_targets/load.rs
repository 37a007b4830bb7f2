//! Feeds arbitrary bytes to `spherebake_runtime::load`, twice: as given, and with every checksum
//! repaired (so mutations get past the CRCs to the section rules). Whenever a file loads, it is
//! re-encoded and re-read: write → read → write must give identical bytes and an equal model.
#![no_main]

use libfuzzer_sys::fuzz_target;

fn check(bytes: &[u8]) {
    if let Ok(proxy) = spherebake_runtime::load(bytes) {
        let once = proxy.to_bytes();
        let again = spherebake_runtime::load(&once).expect("a re-encoded file loads");
        assert_eq!(again.file(), proxy.file(), "re-read model differs");
        assert_eq!(again.to_bytes(), once, "re-encoding is not deterministic");
    }
}

fuzz_target!(|data: &[u8]| {
    check(data);
    let mut repaired = data.to_vec();
    spherebake_format::repair_checksums(&mut repaired);
    check(&repaired);
});
