//! Every page of the user's guide (docs/guide/src) that holds a Rust block
//! is compiled as a doctest of this crate (the `pages!` list of src/lib.rs),
//! so that no page's example goes untested.

use std::path::Path;

#[test]
fn every_guide_page_with_rust_code_is_a_doctest() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let Ok(pages) = std::fs::read_dir(root.join("docs/guide/src")) else {
        return; // a packaged crate has no guide beside it
    };
    let lib = std::fs::read_to_string(root.join("crates/hookean/src/lib.rs")).unwrap();
    let mut checked = 0;
    for page in pages {
        let path = page.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        if text.contains("```rust") {
            let name = path.file_name().unwrap().to_string_lossy();
            let listed = format!("\"docs/guide/src/{name}\"");
            assert!(
                lib.contains(&listed),
                "{name} has Rust code but is not in lib.rs's pages! list"
            );
            checked += 1;
        }
    }
    assert!(checked >= 5, "only {checked} guide pages with Rust code");
}
