/* 3_superquadric api: owned by its helper until integration */
