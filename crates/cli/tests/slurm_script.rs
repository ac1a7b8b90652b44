//! The Slurm job script has one source of truth, `bench/slurm/render_tiles.sbatch`: the book's page
//! on farms includes that file whole and `bench/slurm/run` submits it. These checks keep the three in step (they read
//! files only; the runner itself needs root and minutes and is not part of the test suite).

use std::path::{Path, PathBuf};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").canonicalize().unwrap()
}

fn read(relative: &str) -> String {
    let path = workspace().join(relative);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The bodies of a Markdown text's fenced code blocks whose info string is `lang`.
fn fenced_blocks(markdown: &str, lang: &str) -> Vec<String> {
    let (mut blocks, mut current): (Vec<String>, Option<String>) = (Vec::new(), None);
    for line in markdown.lines() {
        match current.as_mut() {
            None if line.trim_end() == format!("```{lang}") => current = Some(String::new()),
            None => {}
            Some(_) if line.trim_end() == "```" => blocks.push(current.take().unwrap()),
            Some(body) => {
                body.push_str(line);
                body.push('\n');
            }
        }
    }
    blocks
}

/// The book shows the job script through mdBook's `{{#include}}` of the file itself, in a `bash`
/// block of its own (so it cannot show a stale copy), and the included path is the script.
#[test]
fn the_book_shows_the_job_script_by_including_the_file() {
    let page_path = "docs/book/src/rendering/farms.md";
    let page = read(page_path);
    let shown: Vec<String> =
        fenced_blocks(&page, "bash").into_iter().filter(|b| b.trim_start().starts_with("{{#include")).collect();
    assert_eq!(shown.len(), 1, "{page_path} should include exactly one file in a bash block, found {}", shown.len());
    let target = shown[0].trim().trim_start_matches("{{#include").trim_end_matches("}}").trim();
    let included = workspace().join("docs/book/src/rendering").join(target);
    let included = included.canonicalize().unwrap_or_else(|e| panic!("{page_path} includes {target}: {e}"));
    assert_eq!(included, workspace().join("bench/slurm/render_tiles.sbatch"));
    assert!(read("bench/slurm/render_tiles.sbatch").lines().any(|l| l.starts_with("#SBATCH --array")));
}

#[test]
fn the_fenced_block_reader_finds_blocks_by_language() {
    let text = "a\n```bash\n#SBATCH x\necho\n```\n```sh\nls\n```\n```bash\nb\n```\n";
    assert_eq!(fenced_blocks(text, "bash"), vec!["#SBATCH x\necho\n".to_string(), "b\n".to_string()]);
    assert_eq!(fenced_blocks(text, "sh"), vec!["ls\n".to_string()]);
}

#[test]
fn the_runner_submits_the_script_and_the_default_array_matches_the_default_tile_count() {
    let runner = read("bench/slurm/run");
    assert!(
        runner.lines().any(|l| l.contains("sbatch") && l.contains("render_tiles.sbatch")),
        "bench/slurm/run should submit bench/slurm/render_tiles.sbatch"
    );
    let script = read("bench/slurm/render_tiles.sbatch");
    let number_after = |lead: &str| -> u32 {
        let start = script.find(lead).unwrap_or_else(|| panic!("the script has no `{lead}`")) + lead.len();
        let digits: String = script[start..].chars().take_while(char::is_ascii_digit).collect();
        digits.parse().unwrap_or_else(|e| panic!("`{lead}` is not followed by a number: {e}"))
    };
    let last_task = number_after("#SBATCH --array=0-");
    let default_tiles = number_after("tiles=${TILES:-");
    assert_eq!(last_task + 1, default_tiles, "#SBATCH --array=0-{last_task} is not TILES={default_tiles} tasks");
    assert!(script.contains("--tile \"$i/$tiles\""), "the script should render part i of tiles with --tile");
}
