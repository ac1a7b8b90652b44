//! The registry entry (`Registered::INFO`, its `PARAMS`) is the one parameter table of a model:
//! the book's page of every registered model (`docs/book/src/models/NAME.md`) holds the table
//! generated from it (`fiberlab models --markdown --model NAME`) between the two
//! `registry table` comments, and no model file writes a second table into its `//!` docs.
//!
//! After changing a registry entry (or adding a model), rewrite the pages' tables with
//! `FIBERLAB_BLESS=1 cargo test --release -p fiberlab-scatter --test registry_is_the_one_table`:
//! a page without the comments gets the table after its title, a missing page is created.

use fiberlab_scatter::{MARKDOWN_BEGIN, MARKDOWN_END, registry};
use std::path::{Path, PathBuf};

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn bless() -> bool {
    std::env::var_os("FIBERLAB_BLESS").is_some_and(|v| v != "0")
}

/// The generated block as it stands in a page: the two comment lines around the table.
fn block(table: &str) -> String {
    format!("{MARKDOWN_BEGIN}\n{table}{MARKDOWN_END}\n")
}

/// The page with its generated block replaced by `wanted` (or inserted after the title line
/// when it has none), and whether it had one.
fn with_block(page: &str, wanted: &str) -> Result<String, String> {
    match (page.find(MARKDOWN_BEGIN), page.find(MARKDOWN_END)) {
        (Some(begin), Some(end)) if begin < end => {
            let end = end + MARKDOWN_END.len();
            let end = if page[end..].starts_with('\n') { end + 1 } else { end };
            Ok(format!("{}{wanted}{}", &page[..begin], &page[end..]))
        }
        (None, None) => {
            let title_end = page.find('\n').map_or(page.len(), |i| i + 1);
            Ok(format!("{}\n{wanted}{}", &page[..title_end], &page[title_end..]))
        }
        _ => Err("one of the two `registry table` comments is missing or they are out of order".into()),
    }
}

#[test]
fn every_model_page_holds_the_registry_table() {
    let pages = repository().join("docs/book/src/models");
    let mut problems = Vec::new();
    for entry in registry() {
        let info = entry.info();
        let path = pages.join(format!("{}.md", info.name));
        let wanted = block(&info.markdown(entry.kind()));
        let page = std::fs::read_to_string(&path).ok();
        let fixed = match &page {
            Some(page) => with_block(page, &wanted),
            None => Ok(format!("# {}\n\n{wanted}", info.name)),
        };
        match fixed {
            Ok(fixed) if page.as_deref() == Some(fixed.as_str()) => {}
            Ok(fixed) if bless() => std::fs::write(&path, fixed).expect("writing the page"),
            Ok(_) if page.is_none() => problems.push(format!("{}: no such page", path.display())),
            Ok(_) => problems.push(format!("{}: its table differs from the registry's", path.display())),
            Err(e) => problems.push(format!("{}: {e}", path.display())),
        }
    }
    assert!(
        problems.is_empty(),
        "the book's model pages and the registry disagree:\n  {}\nRewrite the tables from the registry with \
         FIBERLAB_BLESS=1 cargo test --release -p fiberlab-scatter --test registry_is_the_one_table",
        problems.join("\n  ")
    );
}

#[test]
fn the_generated_table_has_one_row_per_parameter_and_escapes_pipes() {
    for entry in registry() {
        let info = entry.info();
        let table = info.markdown(entry.kind());
        let rows: Vec<&str> = table.lines().filter(|l| l.starts_with("| `")).collect();
        assert_eq!(rows.len(), info.params.len(), "{}", info.name);
        for (row, p) in rows.iter().zip(info.params) {
            assert!(row.starts_with(&format!("| `{}` |", p.key)), "{}: {row}", info.name);
            // Five cells: six unescaped pipes.
            let pipes = row.match_indices('|').filter(|&(i, _)| i == 0 || &row[i - 1..i] != "\\").count();
            assert_eq!(pipes, 6, "{}: {row}", info.name);
        }
    }
}

#[test]
fn a_page_gets_its_table_replaced_or_inserted_after_the_title() {
    let wanted = block("new\n");
    let old = format!("# t\n\nbefore\n{}after\n", block("old\n"));
    assert_eq!(with_block(&old, &wanted).unwrap(), format!("# t\n\nbefore\n{wanted}after\n"));
    assert_eq!(with_block("# t\nprose\n", &wanted).unwrap(), format!("# t\n\n{wanted}prose\n"));
    assert!(with_block(&format!("# t\n{MARKDOWN_END}\n"), &wanted).is_err());
}

/// A model file's `//!` docs point to the registry for its parameters instead of repeating
/// them in a table (which nothing would keep equal to `PARAMS`).
#[test]
fn no_model_file_repeats_its_parameter_table() {
    fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("reading crates/scatter/src").flatten() {
            let path = entry.path();
            if path.is_dir() {
                rust_files(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    rust_files(&repository().join("crates/scatter/src"), &mut files);
    let offenders: Vec<String> = files
        .iter()
        .filter_map(|path| {
            let text = std::fs::read_to_string(path).ok()?;
            let line = text.lines().position(|l| {
                let l = l.trim_start();
                l.starts_with("//!") && l.trim_start_matches("//!").trim().starts_with("| parameter |")
            })?;
            Some(format!("{}:{}", path.display(), line + 1))
        })
        .collect();
    assert!(
        offenders.is_empty(),
        "parameter tables in module docs (the registry entry is the one table; point to \
         `fiberlab models --model NAME` and the book's page instead):\n  {}",
        offenders.join("\n  ")
    );
}
