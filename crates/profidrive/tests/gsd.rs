//! The GSD file, parsed by an independent parser (gsd-parser), against what the slave accepts.

use dp_slave::Application;
use profidrive::ppo::Ppo;
use profidrive::prm::{OperationMode, UserPrm};
use profidrive::testing::MockDrive;
use profidrive::ProfidriveApp;

fn gsd_text() -> String {
    let mut text = String::new();
    profidrive::gsd::write(&mut text).unwrap();
    text
}

fn parsed() -> gsd_parser::GenericStationDescription {
    let text = gsd_text();
    gsd_parser::parser::parse(std::path::Path::new(profidrive::gsd::FILE_NAME), &text)
        .unwrap_or_else(|e| panic!("{e}\n{text}"))
}

#[test]
fn every_mandatory_dp_v0_keyword_is_there() {
    let text = gsd_text();
    let keywords = [
        "GSD_Revision",
        "Vendor_Name",
        "Model_Name",
        "Revision",
        "Ident_Number",
        "Protocol_Ident",
        "Station_Type",
        "FMS_supp",
        "Hardware_Release",
        "Software_Release",
        "9.6_supp",
        "19.2_supp",
        "45.45_supp",
        "93.75_supp",
        "187.5_supp",
        "500_supp",
        "1.5M_supp",
        "3M_supp",
        "6M_supp",
        "12M_supp",
        "MaxTsdr_9.6",
        "MaxTsdr_19.2",
        "MaxTsdr_45.45",
        "MaxTsdr_93.75",
        "MaxTsdr_187.5",
        "MaxTsdr_500",
        "MaxTsdr_1.5M",
        "MaxTsdr_3M",
        "MaxTsdr_6M",
        "MaxTsdr_12M",
        "Redundancy",
        "Repeater_Ctrl_Sig",
        "24V_Pins",
        "Min_Slave_Intervall",
        "Modular_Station",
        "Max_Module",
        "Max_Input_Len",
        "Max_Output_Len",
        "Max_Data_Len",
        "Max_Diag_Data_Len",
    ];
    for k in keywords {
        assert!(
            text.lines()
                .any(|l| l.split('=').next().is_some_and(|key| key.trim() == k)),
            "{k} missing"
        );
    }
}

#[test]
fn identity_rates_and_services() {
    let gsd = parsed();
    assert_eq!(gsd.ident_number, dp_consts::ADAPTER_IDENT_NUMBER);
    assert!(gsd.auto_baud_supported && gsd.set_slave_addr_supported && gsd.fail_safe);
    assert!(gsd.freeze_mode_supported && gsd.sync_mode_supported);
    use gsd_parser::SupportedSpeeds as S;
    let all = S::B9600
        | S::B19200
        | S::B45450
        | S::B93750
        | S::B187500
        | S::B500000
        | S::B1500000
        | S::B3000000
        | S::B6000000
        | S::B12000000;
    assert!(gsd.supported_speeds.contains(all));
    let t = &gsd.max_tsdr;
    let declared = [
        t.b9600,
        t.b19200,
        t.b45450,
        t.b93750,
        t.b187500,
        t.b500000,
        t.b1500000,
        t.b3000000,
        t.b6000000,
        t.b12000000,
    ];
    assert_eq!(
        declared, [15; 10],
        "the transceiver answers at min TSDR (11 bit times) at every rate: 15 declared"
    );
    // Never looser than a VPC3+-based slave (shared/reference/gsd/CP24V1.gsd, EASY4711.gsd).
    let vpc3 = [15, 15, 15, 15, 15, 15, 20, 35, 50, 95];
    assert!(
        declared.iter().zip(vpc3).all(|(d, v)| *d <= v),
        "{declared:?}"
    );
    assert_eq!(usize::from(gsd.max_diag_data_length), 8);
}

#[test]
fn each_module_is_a_configuration_chk_cfg_accepts() {
    let gsd = parsed();
    assert_eq!(gsd.available_modules.len(), 6);
    let mut app = ProfidriveApp::new(MockDrive::default());
    for (module, ppo) in gsd.available_modules.iter().zip(Ppo::ALL) {
        assert_eq!(module.name, format!("PPO Type {}", ppo.number()));
        assert_eq!(module.config, ppo.cfg());
        let io = app
            .accept_cfg(&module.config)
            .expect("Chk_Cfg accepts the module");
        assert_eq!(io.inputs, ppo.io_bytes());
        assert!(ppo.io_bytes() <= usize::from(gsd.max_input_length));
    }
}

#[test]
fn the_default_user_parameters_are_what_set_prm_accepts() {
    let gsd = parsed();
    let defaults = gsd_parser::PrmBuilder::new(&gsd.user_prm_data).into_bytes();
    assert_eq!(defaults, UserPrm::DEFAULT.encode());
    let mut app = ProfidriveApp::new(MockDrive::default());
    assert!(app.accept_user_prm(&defaults));
    // A tool's choice through the GSD's own fields parses as that choice.
    let mut builder = gsd_parser::PrmBuilder::new(&gsd.user_prm_data);
    builder.set_prm_from_text("Operation mode", "PROFIdrive (seed 004)");
    builder.set_prm("Cut-off time ms (0 = none)", 250);
    builder.set_prm("WrPZD3", 0xF105);
    let prm = UserPrm::parse(builder.as_bytes()).unwrap();
    assert_eq!(prm.operation, OperationMode::Profidrive);
    assert_eq!(prm.cut_off_ms, 250);
    assert_eq!(prm.wr_pzd[1].0, 0xF105);
    let mut builder = gsd_parser::PrmBuilder::new(&gsd.user_prm_data);
    builder.set_prm_from_text("Operation mode", "ABB Drives (+-20000)");
    assert_eq!(
        UserPrm::parse(builder.as_bytes()).unwrap().operation,
        OperationMode::AbbDrives
    );
}
