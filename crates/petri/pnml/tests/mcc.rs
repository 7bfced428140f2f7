//! Every Model Checking Contest net in testdata/mcc reads with the place, transition
//! and arc counts INDEX.tsv gives, writes back as valid PNML and reads back equal.

mod common;

use petriplc_pnml::{read_file, read_str, write_string, ReadOptions};

const MCC: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../testdata/mcc");

#[test]
fn every_mcc_model_reads_writes_validates_and_reads_back() {
    let index = std::fs::read_to_string(format!("{MCC}/INDEX.tsv")).unwrap_or_else(|e| {
        panic!("{MCC}/INDEX.tsv: {e} (testdata/mcc is part of the repository)")
    });
    let mut lines = index.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines
        .next()
        .expect("INDEX.tsv has a header")
        .split('\t')
        .collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("INDEX.tsv has no {name} column"))
    };
    let (model_col, p_col, t_col, a_col) = (col("model"), col("P"), col("T"), col("A"));
    let schema = format!("{}/ptnet.pntd", common::SCHEMAS);
    let mut problems = Vec::new();
    let mut models = 0;
    for line in lines {
        let fields: Vec<&str> = line.split('\t').collect();
        let field = |i: usize| fields.get(i).copied().unwrap_or("");
        let model = field(model_col);
        let expect: Vec<usize> = [p_col, t_col, a_col]
            .iter()
            .map(|&i| {
                field(i)
                    .parse()
                    .unwrap_or_else(|_| panic!("{model}: bad count `{}`", field(i)))
            })
            .collect();
        models += 1;
        let path = format!("{MCC}/{model}/model.pnml");
        let doc = match read_file(path.as_ref(), &ReadOptions::default()) {
            Ok(doc) => doc,
            Err(e) => {
                problems.push(format!("{model}: does not read:\n{e}"));
                continue;
            }
        };
        let net = &doc.net;
        let got = vec![
            net.places().len(),
            net.transitions().len(),
            net.arcs().len(),
        ];
        if got != expect {
            problems.push(format!(
                "{model}: P/T/A are {got:?}, INDEX.tsv says {expect:?}"
            ));
        }
        let written = write_string(net, Some(&doc.layout));
        if let Err(e) = common::xmllint(&schema, &written) {
            problems.push(format!("{model}: written PNML does not validate: {e}"));
        }
        match read_str(&written, model, &ReadOptions::default()) {
            Ok(back) if back == doc => {}
            Ok(back) if back.net == doc.net => {
                problems.push(format!("{model}: the layout changed"))
            }
            Ok(_) => problems.push(format!("{model}: the net read back differs")),
            Err(e) => problems.push(format!("{model}: written PNML does not read back:\n{e}")),
        }
    }
    assert_eq!(models, 27, "INDEX.tsv lists 27 models");
    assert!(
        problems.is_empty(),
        "{} problems:\n{}",
        problems.len(),
        problems.join("\n")
    );
}
